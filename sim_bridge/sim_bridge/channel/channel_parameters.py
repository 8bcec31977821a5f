"""The channel's parameters: the table channel_node declares (its SCHEMA, with config/channel.yaml's values), the
typed object generated from it and the links' configuration it gives (``channel_config``), which the node and the
in-process runner build their links from. Importable without rclpy, as the runner is."""
from __future__ import annotations

from fic_core.errors import FicInputError
from fic_core.parameter_row import (
    ParameterRow,
    integer,
    number,
    numbers,
    parameter_set,
    rows_by_name,
    switch,
    text,
    texts,
)
from sim_bridge.channel.channel import JITTER_DISTRIBUTIONS, ChannelConfig

CHANNEL_PARAMETERS: dict[str, ParameterRow] = rows_by_name(
    texts("routes", "in_topic:out_topic:pkg/msg/Type for each forwarded stream", read_only=True, optional=True),
    number("delay", 0.0, 10.0, "fixed one-way delay [s]"),
    number("jitter", 0.0, 1.0, "bound on the deviation from delay [s]"),
    text("jitter_distribution", f"one of {JITTER_DISTRIBUTIONS} (normal: sigma = jitter/3, truncated at +-jitter)"),
    switch("allow_reorder", "let jitter reorder messages (false: FIFO, a message waits for its predecessor)"),
    number("drop_probability", 0.0, 1.0, "independent loss probability"),
    numbers("blackout_windows", "link-down windows as a flat list of doubles t0,t1,t0,t1,... [s] (see "
                                "time_reference); unset: none; to clear at run time set [0.0, 0.0] (an empty window)",
            optional=True),
    number("lost_from", -1e9, 1e9, "link lost for good from this time [s] (see time_reference); negative: never"),
    number("rate_cap_hz", 0.0, 10000.0, "at most this many deliveries a second per route, newest first; 0: no cap"),
    integer("seed", -1, 2 ** 31 - 1, "seed of the random draws; negative: from the OS"),
    text("time_reference", "'start': blackout_windows and lost_from are relative to the node clock at node start "
                           "(with use_sim_time and no /clock yet that is sim time 0); 'clock': absolute node clock"),
    number("delivery_rate_hz", 10.0, 10000.0, "how often due messages are released [Hz]; sets the delay "
                                              "resolution"),
    number("statistics_rate_hz", 0.01, 100.0, "/diagnostics rate [Hz]"),
    switch("publish_deliveries", "publish fic_teleop_msgs/ChannelDelivery on /channel/deliveries for each "
                                 "delivery"),
    switch("lockstep_heartbeat", "lockstep: publish this node's clock (std_msgs/Header) on ~/heartbeat after each "
                                 "delivery tick, so that the simulation waits for the channel as for its other "
                                 "peers (sim_bridge/robot/peer_barrier.py); the launcher sets it in lockstep"),
    texts("logged_deliveries", "with publish_deliveries: the out topics whose deliveries go on /channel/deliveries; "
                               "unset: every route's", read_only=True, optional=True),
)
#: The channel's parameters as one typed object, one field a row of CHANNEL_PARAMETERS (fic_core.parameter_row); a
#: list left unset reads as empty (rcl reads an empty list in a params file as no value, so the two are one).
ChannelParameters = parameter_set("ChannelParameters", __name__, "channel", CHANNEL_PARAMETERS.values(),
                                  "The channel's parameters (CHANNEL_PARAMETERS), checked, one field a row.")


def channel_config(parameters: ChannelParameters, origin: float = 0.0) -> ChannelConfig:
    """The links' configuration of ``parameters`` (FicInputError for a value its row cannot refuse alone: the time
    reference, an odd count of blackout bounds). ``origin``: the node clock at start [s], which blackout_windows and
    lost_from count from with time_reference 'start'."""
    p = parameters
    if p.time_reference not in ("start", "clock"):
        raise FicInputError(f"time_reference must be 'start' or 'clock', got {p.time_reference!r}")
    offset = origin if p.time_reference == "start" else 0.0
    flat = p.blackout_windows   # numbers, checked by the row
    if len(flat) % 2:
        raise FicInputError(f"blackout_windows needs pairs t0,t1; got {len(flat)} numbers")
    windows = tuple((flat[i] + offset, flat[i + 1] + offset) for i in range(0, len(flat), 2))
    return ChannelConfig(delay=p.delay, jitter=p.jitter, jitter_distribution=p.jitter_distribution,
                         allow_reorder=p.allow_reorder, drop_probability=p.drop_probability,
                         blackout_windows=windows, lost_from=None if p.lost_from < 0.0 else p.lost_from + offset,
                         rate_cap_hz=p.rate_cap_hz, seed=None if p.seed < 0 else p.seed)
