"""The node runtime every fic_teleop node runs on: its main() (node_main.run_node), the spin loop (spin), the
stop-signal handling (stop_signals), the parameter schema and its checks (parameters), QoS profiles (qos), stamp
and geometry conversions (stamps, geometry), CDR header stamps (cdr_header), message classes by type name
(message_types), typed params files (params_file), the log lines of refused inputs and fic_core's notices
(notices), and where config/, the working folder and the installed executables are (workspace). docs/ARCHITECTURE.md
says why it lives here.

Importing this package first thing in a node package takes SIGINT and SIGTERM if the launcher started the process
with them blocked (stop_signals.py): a stop during the imports that follow then ends the process cleanly.
"""
from fic_teleop_runtime import stop_signals as _stop_signals

_stop_signals.install_if_blocked()
