"""Keep one run's graph to itself: a ROS domain reserved on this machine, and a refusal to join a domain that is busy.

Two runs on one domain read each other's /clock, joint states and commands (measured before this module: two
runs started 5 s apart both exited 0 with hundreds of limit-violation ticks and a 776 N peak force). So the
launcher:

- takes a domain through rclpy's ``domain_coordinator`` when none is given (``--domain-id`` or ROS_DOMAIN_ID),
  the same reservation the test suite takes (test/conftest.py ``reserved_domain``): a TCP port
  ``PORT_BASE + domain`` bound on this machine for as long as the run lasts. The operating system frees it when the
  launcher ends, however it ends (even SIGKILL), so a reservation never outlives its run;
- listens on the domain before anything starts (``graph_heard``): a domain that already carries nodes is refused
  when it was given, and skipped when it was chosen, because a process that does not take reservations (a ROS
  tool, another program, a run started with an explicit domain) can be on any domain.

The reservation is only as good as every launcher and test taking it; the probe is what catches the rest. Neither
is a security boundary (docs/SECURITY.md).
"""
from __future__ import annotations

import random
import socket
import time

from domain_coordinator.impl import PORT_BASE

# ROS 2 domain ids that map to valid UDP ports on Linux (the ROS 2 "domain id" rules): 0-101 and 215-232.
VALID_DOMAIN_RANGES = ((0, 101), (215, 232))
# The coordinator's own range (it hands out 1-100; domain 0 stays the default of everything not launched here).
RESERVABLE_DOMAINS = range(1, 101)
# How long the probe listens for another graph. A node on localhost was heard 1.0-2.5 s after the probe started
# (rclpy start, participant discovery, then the node names that rmw_fastrtps sends on its graph topic; 6 fresh
# probes on the loaded 2-core machine), and once, in a fresh-clone suite on a quiet machine, not within 3 s: a
# participant whose first announcements are missed is found at its next periodic one, and Fast DDS announces every
# 3 s by default. 5 s covers one period after the start; a quiet domain costs the launcher this long at start.
PROBE_SECONDS = 5.0
# Topics every rclpy node (our probe included) creates: not a sign of another graph by themselves.
OWN_TOPICS = {"/rosout", "/parameter_events"}


class DomainBusy(RuntimeError):
    """The chosen or given domain carries another graph; the message names what was heard."""


def valid_domain(domain: int) -> bool:
    return any(low <= domain <= high for low, high in VALID_DOMAIN_RANGES)


class DomainReservation:
    """A domain id held on this machine through domain_coordinator's port, until ``release`` or process exit."""

    def __init__(self, domain: int, sock: socket.socket | None) -> None:
        self.domain = domain
        self._socket = sock

    @property
    def held(self) -> bool:
        """Whether this process holds the coordinator's port of the domain (False: a given domain someone else
        reserved, e.g. a test that reserved it for this launcher)."""
        return self._socket is not None

    def release(self) -> None:
        if self._socket is not None:
            self._socket.close()
            self._socket = None

    @staticmethod
    def try_hold(domain: int) -> "DomainReservation | None":
        """Bind the coordinator's port for ``domain``; None if another process holds it. The socket is not
        inherited by the nodes (Python sockets are close-on-exec), so it dies with the launcher alone."""
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            sock.bind(("", PORT_BASE + domain))
        except OSError:
            sock.close()
            return None
        return DomainReservation(domain, sock)


def graph_heard(domain: int, seconds: float = PROBE_SECONDS) -> list[str]:
    """The nodes (and their topics) another graph has on ``domain``, heard within ``seconds``; [] if none.

    A private rclpy context on that domain with one node that only listens; it leaves as soon as it hears
    anything, so a busy domain costs the probe a few hundred milliseconds and a quiet one ``seconds``."""
    import rclpy

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    own_name = f"fic_teleop_domain_probe_{random.getrandbits(32):08x}"
    heard: list[str] = []
    try:
        node = rclpy.create_node(own_name, context=context, enable_rosout=False, start_parameter_services=False)
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            time.sleep(0.05)
            nodes = [f"{namespace.rstrip('/')}/{name}" for name, namespace in node.get_node_names_and_namespaces()
                     if name != own_name]
            if nodes:
                time.sleep(0.2)  # let the rest of that graph's names arrive, for a more useful line
                nodes = sorted({f"{namespace.rstrip('/')}/{name}" for name, namespace
                                in node.get_node_names_and_namespaces() if name != own_name})
                topics = sorted(name for name, _ in node.get_topic_names_and_types() if name not in OWN_TOPICS)
                heard = nodes + topics
                break
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
    return heard


def _describe(heard: list[str], limit: int = 6) -> str:
    shown = ", ".join(heard[:limit])
    return shown + (f" and {len(heard) - limit} more" if len(heard) > limit else "")


def isolate(given: int | None, probe_seconds: float = PROBE_SECONDS, attempts: int = 5) -> DomainReservation:
    """The domain this run uses, held for the run. ``given``: the domain asked for (refused with DomainBusy if a graph
    is heard on it); None: a reserved domain where no graph is heard (up to ``attempts`` reserved domains tried)."""
    if given is not None:
        reservation = DomainReservation.try_hold(given) or DomainReservation(given, None)
        heard = graph_heard(given, probe_seconds)
        if heard:
            reservation.release()
            raise DomainBusy(f"domain {given} already carries a graph ({_describe(heard)}): two graphs on one domain "
                             "read each other's clock, joint states and commands; give another --domain-id or none")
        return reservation
    candidates = list(RESERVABLE_DOMAINS)
    start = random.randrange(len(candidates))  # parallel launchers do not all race for the first free domain
    candidates = candidates[start:] + candidates[:start]
    busy: list[str] = []
    for domain in candidates:
        reservation = DomainReservation.try_hold(domain)
        if reservation is None:
            continue
        heard = graph_heard(domain, probe_seconds)
        if not heard:
            return reservation
        reservation.release()
        busy.append(f"{domain} ({_describe(heard, 2)})")
        if len(busy) >= attempts:
            break
    raise DomainBusy("no free ROS domain: " + ("; ".join(busy) if busy else "every domain 1-100 is reserved on this "
                                                "machine") + "; give one with --domain-id")
