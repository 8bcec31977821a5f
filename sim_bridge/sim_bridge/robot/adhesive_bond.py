"""The adhesive bond between the end-effector plate and a piece (the paper's Velcro strap, experiment E2).

A bond forms when the plate presses on a piece with at least ``formation_force`` for ``formation_time`` (hooks
engaging the pile; a contact spike when the plate lands does not count), holds
while the force it transmits stays below a break threshold, and breaks above it. The paper's Velcro gives an
"inconsistent bond", so the threshold is drawn anew for every bond from a seeded normal distribution (clipped).

The bond is a MuJoCo weld equality (hand <-> piece), one per piece, inactive in the model and switched on at run
time through ``data.eq_active`` with the relative pose of the moment it forms, so the piece is held rigidly by the
constraint solver (implicit, stable at 1 ms) rather than by a stiff explicit spring. The force it transmits is the
weld's constraint force on the piece (see ``_wrench_on_hand``). After a break, a piece cannot bond again until the plate
has left it: a pull that just broke the bond must not re-form it on the next millisecond.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from .wrist_wrench import cross


@dataclass(frozen=True)
class BondParameters:
    formation_force: float = 3.0  # [N] normal force plate->piece that makes the hooks engage...
    formation_time: float = 0.1  # [s] ...held this long: the transient of the plate landing (30-50 ms) does not
    break_force_mean: float = 12.0  # [N]
    break_force_sd: float = 3.0  # [N]
    break_force_min: float = 5.0  # [N] clip: a bond always holds a piece's weight (0.3 N) and some handling
    break_force_max: float = 20.0  # [N]


@dataclass
class BondState:
    bonded_piece: str | None = None
    bond_force: float = 0.0  # [N] magnitude of the force the bond transmits now
    break_threshold: float = 0.0  # [N] of the current bond
    bonds_formed: int = 0
    breaks: int = 0
    last_break_force: float = 0.0
    events: list[str] = field(default_factory=list)  # human-readable, drained by the caller (node logs them)


def add_bond_welds(spec: mujoco.MjSpec, hand_body: str, piece_bodies: tuple[str, ...]) -> None:
    """Add one inactive weld (hand -> piece) per piece. Relative pose is set when the bond forms."""
    for piece in piece_bodies:
        spec.add_equality(name=f"bond_{piece}", type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_BODY,
                          name1=hand_body, name2=piece, active=False,
                          data=[0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0])


class AdhesiveBond:
    """Forms, holds and breaks the plate-piece bond; call ``update`` once per physics step after the forces."""

    def __init__(self, model: mujoco.MjModel, plate_geom: str, hand_body: str, piece_bodies: tuple[str, ...],
                 rng: np.random.Generator, parameters: BondParameters = BondParameters()) -> None:
        self._parameters = parameters
        self._rng = rng
        self._plate_geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, plate_geom)
        self._hand_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, hand_body)
        self._pieces = piece_bodies
        self._piece_ids = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p) for p in piece_bodies])
        self._weld_ids = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"bond_{p}")
                                   for p in piece_bodies])
        if self._plate_geom < 0 or self._hand_body < 0 or np.any(self._piece_ids < 0) or np.any(self._weld_ids < 0):
            raise ValueError("the model lacks the plate geom, the hand, a piece body or its bond weld")
        self._piece_of_geom = {g: int(np.flatnonzero(self._piece_ids == model.geom_bodyid[g])[0])
                               for g in range(model.ngeom) if model.geom_bodyid[g] in self._piece_ids}
        self._press_steps = np.zeros(len(piece_bodies), dtype=int)  # consecutive steps pressed firmly enough
        self._formation_steps = max(1, round(parameters.formation_time / model.opt.timestep))
        self._must_separate: set[int] = set()  # piece indices that broke and have not yet left the plate
        self._active: int | None = None
        self.state = BondState()

    def reset(self, data: mujoco.MjData, rng: np.random.Generator) -> None:
        self._rng = rng
        for weld in self._weld_ids:
            data.eq_active[weld] = 0
        self._active = None
        self._must_separate.clear()
        self._press_steps[:] = 0
        self.state = BondState()

    def _draw_threshold(self) -> float:
        p = self._parameters
        return float(np.clip(self._rng.normal(p.break_force_mean, p.break_force_sd), p.break_force_min,
                             p.break_force_max))

    def _wrench_on_hand(self, model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray) -> np.ndarray:
        """Wrench the active weld applies to the hand, about ``point``, world frame.

        Read from the piece's side, where it is unambiguous: the weld's generalised force on the piece's free
        joint is the force (world frame) and torque (piece frame) on the piece, and the hand receives the
        opposite. (The weld's own constraint rows mix translation and rotation, so their norm is not the force.)
        """
        weld = self._weld_ids[self._active]
        piece = self._piece_ids[self._active]
        rows = (data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (data.efc_id == weld)
        vector = np.where(rows, data.efc_force, 0.0)
        generalised = np.zeros(model.nv)
        mujoco.mj_mulJacTVec(model, data, generalised, vector)
        dof = model.jnt_dofadr[model.body_jntadr[piece]]
        force_on_piece = generalised[dof:dof + 3]
        torque_on_piece = data.xmat[piece].reshape(3, 3) @ generalised[dof + 3:dof + 6]  # about the piece's origin
        torque_on_hand = -(torque_on_piece + cross(data.xpos[piece] - point, force_on_piece))
        return np.concatenate([-force_on_piece, torque_on_hand])

    def _plate_normal_forces(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray | None:
        """Normal contact force between the plate and each piece (0 when not touching); None when the plate
        touches nothing at all (every force 0)."""
        if data.ncon == 0:
            return None
        contacts = data.contact
        # Python lists and a dict, not numpy: with tens of contacts, per-call numpy overhead dominates at 1 kHz.
        geom1, geom2 = contacts.geom1.tolist(), contacts.geom2.tolist()
        if self._plate_geom not in geom1 and self._plate_geom not in geom2:
            return None
        forces = np.zeros(len(self._pieces))
        active = contacts.efc_address.tolist()
        wrench = np.zeros(6)
        for i in range(data.ncon):
            if geom1[i] == self._plate_geom:
                piece = self._piece_of_geom.get(geom2[i])
            elif geom2[i] == self._plate_geom:
                piece = self._piece_of_geom.get(geom1[i])
            else:
                continue
            if piece is not None and active[i] >= 0:
                mujoco.mj_contactForce(model, data, i, wrench)
                forces[piece] += wrench[0]
        return forces

    def update(self, model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray) -> np.ndarray:
        """Call once per step after the forces: returns the bond's wrench on the hand about ``point`` (world
        frame; zeros without a bond), then breaks an overloaded bond or forms one on a firm press."""
        if self._active is not None:
            wrench = self._wrench_on_hand(model, data, point)
            linear = wrench[:3]
            force = math.sqrt(float(linear.dot(linear)))   # np.linalg.norm's value, without its dispatch, at 1 kHz
            self.state.bond_force = force
            if force > self.state.break_threshold:
                data.eq_active[self._weld_ids[self._active]] = 0
                self.state.breaks += 1
                self.state.last_break_force = force
                self.state.events.append(f"bond with {self._pieces[self._active]} broke at {force:.1f} N "
                                         f"(threshold {self.state.break_threshold:.1f} N)")
                self._must_separate.add(self._active)
                self._active = None
                self.state.bonded_piece = None
                self.state.bond_force = 0.0
            return wrench  # it acted during this step, up to the break
        normal = self._plate_normal_forces(model, data)
        if normal is None:
            if self._parameters.formation_force > 0.0:
                # The plate touches nothing (most steps): no press counts on, no broken piece is still on the plate,
                # nothing forms (what the general case below gives for zero forces, without its arrays).
                if self._press_steps.any():
                    self._press_steps[:] = 0
                self._must_separate.clear()
                return np.zeros(6)
            normal = np.zeros(len(self._pieces))
        firm = normal >= self._parameters.formation_force
        self._press_steps = np.where(firm, self._press_steps + 1, 0)
        self._must_separate = {k for k in self._must_separate if normal[k] > 0.0}
        candidates = [k for k in range(len(normal))
                      if self._press_steps[k] >= self._formation_steps and k not in self._must_separate]
        if candidates:
            self._form(model, data, max(candidates, key=lambda k: normal[k]))
        return np.zeros(6)

    def _form(self, model: mujoco.MjModel, data: mujoco.MjData, index: int) -> None:
        weld = self._weld_ids[index]
        piece = self._piece_ids[index]
        # Weld data: anchor (piece frame) 0:3, piece origin in the hand frame 3:6, piece orientation relative to
        # the hand 6:10, torque scale 10. Setting the current relative pose makes the bond form without a jerk.
        hand_rotation = data.xmat[self._hand_body].reshape(3, 3)
        relative_position = hand_rotation.T @ (data.xpos[piece] - data.xpos[self._hand_body])
        hand_inverse = np.zeros(4)
        mujoco.mju_negQuat(hand_inverse, data.xquat[self._hand_body])
        relative_quat = np.zeros(4)
        mujoco.mju_mulQuat(relative_quat, hand_inverse, data.xquat[piece])
        model.eq_data[weld, 0:3] = 0.0
        model.eq_data[weld, 3:6] = relative_position
        model.eq_data[weld, 6:10] = relative_quat
        model.eq_data[weld, 10] = 1.0
        data.eq_active[weld] = 1
        self._active = index
        self.state.bonded_piece = self._pieces[index]
        self.state.break_threshold = self._draw_threshold()
        self.state.bonds_formed += 1
        self._press_steps[:] = 0
        self.state.bond_force = 0.0
        self.state.events.append(f"bond with {self._pieces[index]} formed "
                                 f"(breaks above {self.state.break_threshold:.1f} N)")

    def drain_events(self) -> list[str]:
        events, self.state.events = self.state.events, []
        return events
