"""E2 (shape sorting, docs/EXPERIMENTS.md "E2"): its trials in process and on the graph, the sweep over laws, delays
and seeds, and the reading of the bond's force in each pull, under one command line:

    python -m fic_teleop_experiments.e2 trial ...        # in-process trials, seeds 1..N (trial.py)
    python -m fic_teleop_experiments.e2 sweep ...        # every law at every delay, resumable jsonl, on the engine
    python -m fic_teleop_experiments.e2 graph ...        # trials on the DDS graph in lockstep, resumable jsonl
    python -m fic_teleop_experiments.e2 bond-pulls ...   # the bond's, the law's and the F/T force in each pull

One concept a file: ``outcome`` (what a trial's operator log and trace say: the pieces, their phases, the forces),
``jsonl`` (the resumable files every driver reads and appends), ``trial`` (one in-process trial and its report),
``sweep``, ``graph``, ``bond_pulls``, and ``command_line`` (the subcommands; ``__main__`` runs it). Importing this
package imports none of them.
"""
