"""A node's values from its file under config/ (the ``/**`` section): the one home of the defaults, which the core
tests start from as the nodes do."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from fic_core.replica_parameters import REPLICA_LOOP_PARAMETERS, ReplicaLoopParameters

CONFIG = Path(__file__).resolve().parents[1] / "config"


def config_values(file_name: str) -> dict[str, Any]:
    return dict(yaml.safe_load((CONFIG / file_name).read_text())["/**"]["ros__parameters"])


def replica_loop_values(**changes: Any) -> dict[str, Any]:
    """config/replica.yaml's ReplicaLoop parameters (not the node's driver or input-authority keys), changed."""
    values = {name: value for name, value in config_values("replica.yaml").items() if name in REPLICA_LOOP_PARAMETERS}
    return {**values, **changes}


def replica_loop_parameters(**changes: Any) -> ReplicaLoopParameters:
    """``replica_loop_values`` as the loop takes them, each checked by its row."""
    return ReplicaLoopParameters.from_values(replica_loop_values(**changes))
