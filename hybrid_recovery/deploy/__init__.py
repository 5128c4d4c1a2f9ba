"""Hardware deployment: the Unitree low-level protocol, transport and runners."""
