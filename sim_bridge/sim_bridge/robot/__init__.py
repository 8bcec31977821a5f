"""The simulated robot: the MuJoCo Panda and its scenes (the bond, the wrist wrench), the stepping modes, the
command watchdog, rendering, and the robot node that serves /joint_states and takes /joint_torque_command."""
