"""Master side of FIC haptic teleoperation: the master FIC with online haptic gain and the teleoperation modes (paper Eq. 3)."""
