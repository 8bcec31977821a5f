"""A message type's name as the graph gives it (``pkg/msg/Type``) -> its Python class.

rosidl_runtime_py is not in the wheels; the channel, the recorder and the robot's lockstep peers all need the class
of a topic's type to subscribe to it, even raw.
"""
from __future__ import annotations

import importlib

from fic_core.errors import FicInputError


def message_class(type_name: str) -> type:
    """``pkg/msg/Type`` -> the Python message class; FicInputError (a ValueError) if it is malformed or unknown."""
    parts = type_name.split("/")
    if len(parts) != 3 or parts[1] != "msg":
        raise FicInputError(f"message type must look like pkg/msg/Type, got {type_name!r}")
    try:
        return getattr(importlib.import_module(f"{parts[0]}.msg"), parts[2])
    except (ImportError, AttributeError) as exc:
        raise FicInputError(f"unknown message type {type_name!r}: {exc}") from exc
