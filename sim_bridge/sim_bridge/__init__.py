"""The simulated world: MuJoCo Panda with the paper's scenes, a sigma.7-class haptic device with a virtual operator, the delay/dropout channel, and the MCAP recorder."""
