"""The simulated haptic device (a sigma.7-class handle) and its operators: the scripted virtual hand, the
operator scripts, and the keyboard operator."""
