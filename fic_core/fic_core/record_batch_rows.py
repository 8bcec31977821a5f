"""The row every node with a fast recorded stream declares (the robot, the replica, the device, the master): how its
samples travel to the recorder (fic_teleop_runtime/record_batch.py: many to a message, every sample kept)."""
from __future__ import annotations

from .parameter_row import ParameterRow, number, rows_by_name

RECORD_BATCH_ROWS: dict[str, ParameterRow] = rows_by_name(
    number("record_batch_period", 0.0, 1.0, "seconds of a fast stream's samples carried to the recorder in one "
                                            "/record/<topic> message (every sample kept; the topic itself is "
                                            "published while it has readers); 0: one message a sample, as any "
                                            "publisher [s]", read_only=True),
)
