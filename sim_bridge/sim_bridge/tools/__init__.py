"""Tools that run beside the graph: the starvation harness (stress.py) and the seeded random mutation run over
fic_core (random_mutation.py). Each has a command-line entry in scripts/ (stress.sh, random_mutation.py)."""
