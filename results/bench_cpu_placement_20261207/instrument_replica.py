"""Patch the replica node (a working-tree edit: `git checkout` it afterwards) to count its main thread's CPU time
(time.thread_time_ns) in the joint-state callback, in the law's tick (ReplicaStation.named_joint_state) and in the
torque command's publish, and print the totals when the node stops ("PROF thread_cpu ..." in its log).

    python results/bench_cpu_placement_20261207/instrument_replica.py
"""
from pathlib import Path

NODE = Path(__file__).resolve().parents[2] / "fic_teleop_replica" / "fic_teleop_replica" / "replica_node.py"

CALLBACK = '''    def _on_joint_state_bytes(self, data: bytes) -> None:
        """The joint state as CDR bytes: its header stamp tells whether it is needed; the others are counted and
        dropped unconverted (a JointState costs tens of microseconds)."""
'''
TIMED_CALLBACK = '''    def _on_joint_state_bytes(self, data: bytes) -> None:
        import time as _t
        _a = _t.thread_time_ns()
        try:
            self._js_inner(data)
        finally:
            _PROF["js"] += _t.thread_time_ns() - _a
            _PROF["js_n"] += 1

    def _js_inner(self, data: bytes) -> None:
        import time as _t
'''
LAW = '''        tick, error = station.named_joint_state(stamp_ns * 1e-9, self._now(), message.name, message.position,
                                                message.velocity, stamp_ns, self._steady_now())
'''
TIMED_LAW = '''        _b = _t.thread_time_ns()
''' + LAW + '''        _PROF["law"] += _t.thread_time_ns() - _b
'''
PUBLISH = '''        self._publish_command(tick.command, tick.state_stamp_ns)
        if tick.hold_began:'''
TIMED_PUBLISH = '''        _b = _t.thread_time_ns()
        self._publish_command(tick.command, tick.state_stamp_ns)
        _PROF["pubcmd"] += _t.thread_time_ns() - _b
        if tick.hold_began:'''
STOPPED = '''    rclpy.logging.get_logger(NODE_NAME).info(f"{STOPPED_LINE}{node.statistics()}")
'''
PRINTED = STOPPED + '''    import time as _t
    totals = ", ".join(f"{k} {v if k.endswith('_n') else v / 1e9:.3f}" for k, v in _PROF.items())
    print(f"PROF thread_cpu {_t.thread_time():.2f} s; {totals}", flush=True)
'''
MARK = "#: The replica's last log line begins so"
COUNTER = "from collections import Counter as _Counter\n_PROF = _Counter()\n" + MARK

text = NODE.read_text()
for old, new in ((CALLBACK, TIMED_CALLBACK), (LAW, TIMED_LAW), (PUBLISH, TIMED_PUBLISH), (STOPPED, PRINTED),
                 (MARK, COUNTER)):
    if text.count(old) != 1:
        raise SystemExit(f"{NODE}: the text to patch is not there once (already patched, or the node changed)")
    text = text.replace(old, new)
NODE.write_text(text)
print(f"patched {NODE}")
