"""The network between master and replica: the delay, jitter, dropout and blackout model and its node."""
