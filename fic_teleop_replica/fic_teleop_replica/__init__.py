"""Replica side: the FIC torque controller with postural optimisation for a Panda-class arm (paper Eq. 7)."""
