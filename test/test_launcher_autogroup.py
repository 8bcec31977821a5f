"""The launcher's node niceness reaches the node's own session (its autogroup), not only its threads.

Under the kernel's autogroup scheduling each session is one scheduling entity; a node started in a session of its
own at niceness -12 competed with every other session as a niceness-0 entity (fic_teleop_bringup.teleop_launcher
_prioritised; docs/RESULTS.md "Tick gaps").
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fic_teleop_bringup.teleop_launcher import _prioritised, autogroup_niceness

pytestmark = pytest.mark.skipif(os.geteuid() != 0 or not Path("/proc/self/autogroup").exists(),
                                reason="needs root and the kernel's autogroup scheduling")

READ = "import os; print(os.getpriority(os.PRIO_PROCESS, 0), open('/proc/self/autogroup').read().split()[-1])"


def _child(new_session: bool, niceness: int) -> tuple[int, int]:
    out = subprocess.run([sys.executable, "-c", READ], start_new_session=new_session,
                         preexec_fn=_prioritised(niceness), capture_output=True, text=True, check=True, timeout=30)
    process_niceness, group_niceness = out.stdout.split()
    return int(process_niceness), int(group_niceness)


def test_a_node_in_its_own_session_gets_the_niceness_on_its_autogroup():
    assert _child(new_session=True, niceness=-3) == (-3, -3)


def test_a_node_in_the_launchers_session_leaves_the_sessions_autogroup_alone():
    before = autogroup_niceness(os.getpid())
    process_niceness, group_niceness = _child(new_session=False, niceness=-3)
    assert process_niceness == -3
    assert group_niceness == before == autogroup_niceness(os.getpid())


def test_autogroup_niceness_reads_a_process_and_says_none_for_a_gone_one():
    assert isinstance(autogroup_niceness(os.getpid()), int)
    assert autogroup_niceness(2 ** 22 + 12345) is None
