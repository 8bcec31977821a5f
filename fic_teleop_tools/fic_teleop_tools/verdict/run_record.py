"""What a launcher's run folder says about the run itself (run.json), for the tools that judge its bag."""
from __future__ import annotations

import json
from pathlib import Path


def quiet_from(run_dir: Path | None) -> float | None:
    """The stamp the run's quiet tail starts at, as the launcher wrote it in run.json (--quiet-tail); None when
    the run has none or the bag is not in a run folder."""
    try:
        value = json.loads((run_dir / "run.json").read_text()).get("quiet_from") if run_dir is not None else None
    except (OSError, ValueError):
        return None
    return float(value) if isinstance(value, (int, float)) and value > 0 else None
