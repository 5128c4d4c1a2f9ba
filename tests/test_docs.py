"""What the documents promise: the README's example runs, its layout table names every
package folder, the docs cite the paper and not files outside the repository, the guides
stay short, and the package metadata carries its license without build warnings."""

from __future__ import annotations

import contextlib
import importlib.metadata
import io
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def test_readme_quick_start_runs_and_prints_the_balance_state():
    code = re.search(r"```python\n(.*?)```", README.read_text(), re.S)
    assert code is not None, "README has no python example"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code.group(1), "README.md", "exec"), {})
    numbers = [float(x) for x in re.findall(r"-?\d+\.\d+(?:e[-+]\d+)?", out.getvalue())]
    assert len(numbers) == 3 + 2 + 3 + 3  # c, ξ, p_l, L
    # translating at 0.3 m/s: p_l,x = m · 0.3 with m = 66.984 kg; ξ_x = c_x + 0.3 / ω
    assert numbers[5] == pytest.approx(66.984 * 0.3, rel=1e-3)
    omega = (9.81 / numbers[2]) ** 0.5
    assert numbers[3] == pytest.approx(numbers[0] + 0.3 / omega, rel=1e-3)


def test_readme_layout_names_every_package_and_top_level_folder():
    text = README.read_text()
    packages = sorted(p.parent.name for p in (ROOT / "hybrid_recovery").glob("*/__init__.py"))
    missing = [p for p in packages if f"`hybrid_recovery/{p}/`" not in text]
    assert not missing, f"README layout lacks {missing}"
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True)
    if tracked.returncode != 0:
        pytest.skip("not a git checkout")
    folders = {line.split("/")[0] for line in tracked.stdout.splitlines() if "/" in line}
    folders -= {"hybrid_recovery", ".ci"}
    missing = sorted(f for f in folders if f"`{f}/`" not in text)
    assert not missing, f"README layout lacks {missing}"


def test_documents_cite_the_paper_not_files_outside_the_repository():
    offending = []
    for path in ROOT.rglob("*"):
        if (path.suffix not in (".py", ".md", ".ipynb", ".sh", ".toml")
                or any(part.startswith(".") for part in path.relative_to(ROOT).parts)):
            continue
        text = path.read_text(errors="ignore")
        for pattern in ("SPEC §", "STYLE §", "FACTS.md", "SPEC.md", "STYLE.md"):
            if pattern in text and path != Path(__file__):
                offending.append(f"{path.relative_to(ROOT)}: {pattern}")
    assert not offending


def test_guides_stay_short():
    assert len(README.read_text().splitlines()) <= 110
    assert len((ROOT / "training" / "README.md").read_text().splitlines()) <= 300


def test_wheel_carries_the_license_and_the_build_prints_no_license_warning(tmp_path):
    setuptools = importlib.metadata.version("setuptools")
    if int(setuptools.split(".")[0]) < 77:
        pytest.skip(f"setuptools {setuptools} < 77 cannot build SPDX license metadata")
    source = tmp_path / "source"  # a copy: the build writes build/ and *.egg-info beside it
    shutil.copytree(ROOT / "hybrid_recovery", source / "hybrid_recovery",
                    ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, source / name)
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-v", "--no-deps", "--no-build-isolation",
         "--wheel-dir", str(tmp_path / "dist"), str(source)],
        capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert build.returncode == 0, build.stderr[-2000:]
    log = (build.stdout + build.stderr).lower()
    assert "license" not in "\n".join(line for line in log.splitlines() if "warning" in line)
    (wheel,) = (tmp_path / "dist").glob("hybrid_recovery-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        metadata = archive.read(next(n for n in names if n.endswith("METADATA"))).decode()
        license_file = next(n for n in names if n.endswith("licenses/LICENSE"))
        assert "the hybrid_recovery authors" in archive.read(license_file).decode()
    assert "License-Expression: BSD-3-Clause" in metadata.splitlines()
