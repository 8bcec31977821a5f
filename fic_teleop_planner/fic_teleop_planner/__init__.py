"""Harmonic trajectory planner whose motion is superimposed on the operator's command (paper Eqs. 5-6)."""
