"""Tools that measure or check the project from outside the graph, each run with
``python -m fic_teleop_experiments.tools.<name>`` (docs/TOOLS.md): the benches (bench.py, which scripts/bench.sh runs;
bench_core.py, bench_sim.py, bench_live_view.py), the starvation harness (stress.py, through scripts/stress.sh), the
hand-picked and the seeded random mutation runs over fic_core (mutation_check.py, random_mutation.py, one verdict
reading in mutation_verdict.py), the independent passivity judge of the attractor (passivity_oracle.py,
orientation_loops.py, passivity_cycles.py) and the hostile-input probes of a running graph (fault_probes.py). The live
view's layout writer is fic_teleop_tools.recording.live_view_layout, beside the live view."""
