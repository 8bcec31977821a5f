"""The tail-contact A/B's variants (fic_teleop_experiments.tail_contact): each changes one thing of a claim run."""
import pytest

from fic_teleop_experiments.claims import ClaimRun, duration_for, tail_for
from fic_teleop_experiments.tail_contact import TERMS_OFF, VARIANTS, variant_config


def _claim(controller: str = "fic") -> ClaimRun:
    return ClaimRun(1.0, 10.0, controller, "passive", 7, duration_for(1.0), tail=tail_for(1.0))


def test_as_swept_is_the_claim_run_itself():
    assert variant_config(_claim(), "as swept") == _claim().config()


@pytest.mark.parametrize("variant", sorted(TERMS_OFF))
def test_a_term_off_changes_only_that_replica_parameter(variant):
    swept, changed = _claim("fic_paper_law").config(), variant_config(_claim("fic_paper_law"), variant)
    assert changed.replica_overrides == {"paper_law": True, TERMS_OFF[variant]: False}
    assert changed.duration == swept.duration and changed.quiet_from == swept.quiet_from
    assert changed.master_overrides == swept.master_overrides and changed.seed == swept.seed


def test_the_contact_gate_variant_switches_the_gate_on_and_nothing_else():
    changed = variant_config(_claim(), "contact gate")
    assert changed.replica_overrides == {"offset_feedforward_contact_gate": True}
    assert changed.duration == _claim().config().duration


def test_the_task_variants_move_the_stop_and_keep_the_tail_and_the_law():
    for variant, shift in (("stop 2 s earlier", -2.0), ("stop 2 s later", 2.0)):
        changed = variant_config(_claim(), variant)
        assert changed.quiet_from == _claim().duration + shift
        assert changed.duration - changed.quiet_from == tail_for(1.0)
        assert changed.replica_overrides == {}
    assert variant_config(_claim(), "no force feedback").master_overrides == {"haptic_gain": 0.0}
    assert set(TERMS_OFF) < set(VARIANTS)
    with pytest.raises(ValueError):
        variant_config(_claim(), "no such variant")
