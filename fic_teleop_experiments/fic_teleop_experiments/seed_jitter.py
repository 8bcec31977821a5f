"""What a seed varies in a sweep's in-process run (in_process.RunConfig), besides the task: the same spreads for
the claim runs (claims.py), the E2 trials (e2/trial.py) and the reference runs of the suite."""

CHANNEL_JITTER_S = 0.005         # per-message delay jitter (seeded); the paper's link is a LAN with video
OPERATOR_TIMING_JITTER_S = 0.1   # script clock shift, about half a human reaction time
HAND_IMPEDANCE_JITTER = 0.2      # +-20 % on the hand's stiffness and damping
