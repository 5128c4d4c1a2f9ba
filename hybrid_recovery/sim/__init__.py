"""The simulated world, below the environment, deploy and evaluation.

* ``scene``: the robot, the floor, actuators and the sensors the MDP reads;
* ``initial_states``: the paper's start poses, settled into physically valid states;
* ``render``: offscreen video with the balance quantities drawn in the scene.

Nothing here imports torch.
"""
