"""An option: the teleoperated offset's inertial feedforward waits out a contact's echo (beyond paper Eq. 7;
docs/CONTROL_LAWS.md, "Low-rate links").

The replica feeds the estimated acceleration of x_d' forward through the task-space inertia, J^T Lambda a_d
(fic_core.replica), so that the arm follows the operator's moves in free space without the error the FIC's K0 would
need to produce them. The planner's acceleration comes from outside the loop. x_d''s does not: the handle moves
under the force the replica felt one delay earlier, so an impact of the arm comes back, one round trip of the link
later, as a jolt of x_d' -- and its second derivative fed forward, up to F_max, pushes the arm into the next impact.
At 1 s of delay the FIC's arm, held on E1's fixed obstacle when the task stopped, kept a 4-11 mm cycle with impacts to
170 N; the same runs without the offset feedforward settled on the obstacle (docs/RESULTS.md, "Evidence and claims").
Fading the feedforward by the contact force alone did not stop it: the jolts arrive after the arm has bounced off.

So, when the replica's ``offset_feedforward_contact_gate`` is on, after any contact (the measured |F_R| at or above
``contact_force``, or no usable reading) the offset feedforward is off until the arm has been free for one round trip
of the link -- twice the measured age of the teleoperation commands, the time a contact takes to come back through the
operator -- plus ``settle``; then it acts in full again. In contact and in its echo the FIC alone acts, as the paper's
law does. It settles the tails above, but it also takes the feedforward away after every ordinary contact (the
FIC's peak gain at 10 Hz rose from 0.98-1.09 to 1.11-1.19 with it): so it is off by default (docs/CONTROL_LAWS.md).
"""
from __future__ import annotations

import math

from .errors import FicInputError, finite_scalar


class OffsetFeedforwardGate:
    """Whether the offset feedforward may act now (module docstring). ``contact_force`` [N], ``settle`` [s]."""

    def __init__(self, contact_force: float, settle: float) -> None:
        self.contact_force = finite_scalar("contact_force", contact_force, minimum=0.0, minimum_inclusive=False)
        self.settle = finite_scalar("settle", settle, minimum=0.0)
        self.last_contact = -math.inf   # [s] the last control tick that saw the arm in contact

    def update(self, now: float, measured_force: float, one_way_delay: float) -> bool:
        """At a control tick ``now`` [s] with the latest |F_R| [N] and the link's measured one-way delay [s]: True
        when the offset feedforward may act (free for a round trip + settle since the last contact)."""
        if not math.isfinite(now):
            raise FicInputError(f"now must be finite, got {now}")
        if not (measured_force < self.contact_force):   # NaN, inf (a refused reading) or in contact
            self.last_contact = now
        round_trip = 2.0 * one_way_delay if math.isfinite(one_way_delay) and one_way_delay > 0.0 else 0.0
        return now - self.last_contact >= round_trip + self.settle

    def reset(self) -> None:
        """Forget the contacts seen (a new run)."""
        self.last_contact = -math.inf
