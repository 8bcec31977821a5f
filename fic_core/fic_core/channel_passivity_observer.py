"""The passivity observer of one side of a delayed channel (time-domain passivity, the two-port form).

A delayed channel is a two-port: at the master side it takes a motion in and gives a force out, at the replica side
the reverse. Its energy cannot be summed at one place (the two ports are a delay apart), so each side sums its own
port's power P (positive when energy enters the channel at that port) into an input and an output energy,

    E_in(t) = sum max(P, 0) dt ,      E_out(t) = sum max(-P, 0) dt ,

sends its E_in to the other side with its signal, and watches

    W(t) = E_in,other(t - T) - E_out(t) ,

the energy the other side put in (as far as this side knows, one delay ago) minus what this side has let out. While
every W >= 0 the channel gives out no more than it was given: it is passive whatever the delay (Ryu, Artigas and
Preusche, "A passivity controller for stable haptic interaction with a delayed channel"; Artigas et al., the time
delay power network, 2010). A negative W is energy the delay created; the passivity controller at that side
(fic_core.passivity_controller) dissipates it before it leaves.

The observer only counts: ``tentative`` says what W would be after a tick's power, ``observe`` books it.
"""
from __future__ import annotations

from fic_core.errors import finite_scalar


class ChannelPortObserver:
    """E_in, E_out of this side's port, the other side's E_in as received, and W (module docstring)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.input_energy = 0.0          # E_in of this port [J], sent to the other side
        self.output_energy = 0.0         # E_out of this port [J]
        self.received_input_energy = 0.0  # E_in of the other port, one delay ago [J]
        self.ticks = 0
        self.negative_ticks = 0          # ticks booked with W < 0 (energy the delay created got out)
        self.min_energy = 0.0            # the smallest W over the run [J]

    def receive(self, other_input_energy: float) -> None:
        """The other side's E_in, arrived through the channel. E_in never decreases, so an older figure arriving
        late (a channel that reorders) does not lower what this side knows."""
        value = finite_scalar("other_input_energy", other_input_energy, minimum=0.0)
        if value > self.received_input_energy:
            self.received_input_energy = value

    @property
    def energy(self) -> float:
        """W = E_in,other(t - T) - E_out [J]."""
        return self.received_input_energy - self.output_energy

    def tentative(self, power: float, dt: float) -> float:
        """W after a tick of ``power`` [W] (into the channel at this port) over ``dt`` [s], not booked."""
        return self.energy - max(-power, 0.0) * dt

    def observe(self, power: float, dt: float) -> float:
        """Book one tick of ``power`` [W] over ``dt`` [s]; returns W after it."""
        power = finite_scalar("power", power)
        dt = finite_scalar("dt", dt, minimum=0.0)
        if power > 0.0:
            self.input_energy += power * dt
        else:
            self.output_energy -= power * dt
        self.ticks += 1
        energy = self.energy
        # A deficit at the rounding of the sums (a tick of 1e-12 J) is not a created joule.
        if energy < -1e-9:
            self.negative_ticks += 1
        if energy < self.min_energy:
            self.min_energy = energy
        return energy
