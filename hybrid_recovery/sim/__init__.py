"""The simulated world, below the environment, deploy and evaluation.

* ``scene``: the robot, the floor, actuators and the sensors the MDP reads;
* ``initial_states``: the paper's start poses, settled into physically valid states;
* ``divergence``: whether a simulation has diverged (MuJoCo's instability warnings and
  reset, a non-finite state, a runaway speed), asked by every runner after its steps;
* ``backend``: the batched physics the environment steps, CPU MuJoCo's
  ``mujoco.batch.Batch`` or ``warp_batch.WarpBatch`` (MuJoCo Warp), behind one interface;
* ``render``: offscreen video with the balance quantities drawn in the scene;
  ``gl_backend`` chooses MuJoCo's OpenGL backend before it is imported, and
  ``software_renderer`` draws frames where no OpenGL context can be made.

Nothing here imports torch.
"""
