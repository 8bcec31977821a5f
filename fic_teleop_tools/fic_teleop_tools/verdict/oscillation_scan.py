"""Sustained oscillation at any period: a sinusoid fitted in sliding windows, period by period (docs/EXPERIMENTS.md,
"The run verdict").

The signal scanned is a motion with its known command removed (x_M minus the hand's target, x_R minus the planner
and the operator's target one delay later, x_d - x_R). For every period P of a geometric grid from ``min_period`` to
the longest period the span can hold ``min_cycles`` times, windows of ``cycles_per_window`` periods (shorter when the
span is short, never under ``min_cycles`` periods) slide over the span by half a window. In each window the samples
outside contact are fitted by a line plus a sinusoid of period P; the sinusoid's amplitude and its share of what the
line leaves ("explained share") say whether the window oscillates at P: amplitude above ``amplitude`` AND share
above ``explained_share``. One window is not a sustained oscillation: P is SUSTAINED when at least
``sustained_share`` of the judged windows oscillate at P, the last one among them, with at least ``min_windows``
(3) windows judged (one or two windows are one look, not a sustained oscillation), and the last window's amplitude is
at least ``decay_ratio`` times the first's (an oscillation dying out, a stable loop ringing after a push, is not
sustained; one that grows is, and the energy test says it grows).

Why a fitted sinusoid and not an autocorrelation over laps: the task does not repeat, so nothing periodic is left in
a stable loop's residual to subtract; a sinusoid fit in windows of a few periods is frequency selective (its pass
band is about 1/cycles_per_window of P wide, so neighbouring grid periods, 7 % apart, overlap: a period half-way
between two loses under 3 % of its amplitude) and it reaches periods
as long as the span allows instead of half of it. An operator's aperiodic move is one bump in a window of three
periods: the sinusoid explains little of it, and a bump does not come back in every window.

A window in which the command itself repeats at P along the same axis (a sinusoid of period P explains as much of
the command as a residual's must) with an amplitude at least 1/``forced_share`` times the residual's is the loop's
forced answer to that command (a replica lagging a planner that circles at P, a
hand giving way to the force that lag sends back), not an oscillation of its own: such a window does not count as
oscillating. run_verdict uses this excuse only where it cannot fit the loop's forced answer to its exogenous input
(fic_teleop_tools.verdict.forced_answer), which replaces it: its blind spot, a limit cycle along an axis and at a
period where the command moves over the whole span, smaller than ``forced_share`` of the command there (50 mm
against the paper's 0.20 m circle at its lap period), taken for the forced answer; and a loop whose answer at P is
more than ``forced_share`` of its command (|H - 1| > 0.5, an under-damped replica at its resonance), whose forced
swing is never excused.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class ScanSettings:
    min_period: float = 0.2          # [s] faster is contact chatter or sensor noise
    period_step: float = 1.07        # ratio of neighbouring grid periods
    cycles_per_window: float = 3.0   # periods in a window
    min_cycles: float = 1.5          # periods a window must hold at least (long periods in short spans)
    amplitude: float = 0.003         # [m] fitted sinusoid amplitude a window must exceed (6 % of x_b)
    explained_share: float = 0.5     # share of the window's detrended variance the sinusoid must explain ...
    explained_share_few_cycles: float = 0.85  # ... when the span holds fewer than 2 cycles_per_window periods
    sustained_share: float = 0.8     # windows at one period that must oscillate ...
    min_windows: int = 3             # ... of at least this many judged windows (one or two are not "sustained")
    decay_ratio: float = 0.7         # last / first window amplitude under this: dying out (energy halved)
    forced_share: float = 0.5        # residual under this share of the command's amplitude at P: forced answer
    free_share: float = 0.8          # a window is judged when this share of it is outside contact
    samples_per_period: int = 12     # the series is block-averaged to about this many samples a period
    max_period: float | None = None  # [s] the longest period scanned (None: the longest the span holds)


@dataclass
class Oscillation:
    """The scan's finding for one signal: the sustained period of largest amplitude, else the period whose windows
    came closest (largest share of oscillating windows)."""

    sustained: bool
    period: float                    # [s] (0 when no window was judged)
    amplitude: float                 # [m] mean fitted amplitude over the oscillating windows at that period
    explained_share: float           # mean over those windows
    window_share: float              # oscillating windows / judged windows at that period
    windows: int                     # judged windows at that period
    amplitude_ratio: float           # last window's amplitude / first's
    longest_period: float            # [s] longest period the span holds min_cycles times (the scan's reach)

    def as_dict(self) -> dict:
        return {name: (round(value, 5) if isinstance(value, float) else value) for name, value in vars(self).items()}


def periods(settings: ScanSettings, longest: float) -> NDArray[np.float64]:
    """The period grid: geometric from ``min_period`` to ``longest`` (both included)."""
    if longest < settings.min_period:
        return np.zeros(0)
    count = int(np.floor(np.log(longest / settings.min_period) / np.log(settings.period_step))) + 1
    grid = settings.min_period * settings.period_step ** np.arange(count)
    return grid if np.isclose(grid[-1], longest) else np.append(grid, longest)


def _fits(time: NDArray, values: NDArray, weights: NDArray, index: NDArray, period: float
          ) -> tuple[NDArray, NDArray]:
    """(amplitude, explained share), each (windows, k), of a line plus a sinusoid of ``period`` fitted by weighted
    least squares to ``values`` (n, k) in every window of sample indices ``index`` (windows, m)."""
    local = time[index] - time[index].mean(axis=1, keepdims=True)
    phase = 2.0 * np.pi * local / period
    basis = np.stack([np.ones_like(local), local, np.sin(phase), np.cos(phase)], axis=2)   # (w, m, 4)
    w = weights[index][:, :, None]
    y = values[index]                                                                       # (w, m, k)
    weighted = (basis * w).transpose(0, 2, 1)                                               # (w, 4, m)
    gram = weighted @ basis
    moments = weighted @ y
    coefficients = np.linalg.solve(gram, moments)                                           # (w, 4, k)
    line = np.linalg.solve(gram[:, :2, :2], moments[:, :2])                                 # (w, 2, k)
    # Weighted sums of squares left by each fit: sum w y^2 - c^T (B^T W y) for least-squares c.
    total = np.sum(w * y * y, axis=1)
    left_by_full = total - np.einsum("wik,wik->wk", coefficients, moments)
    left_by_line = total - np.einsum("wik,wik->wk", line, moments[:, :2])
    explained = np.where(left_by_line > 1e-300, 1.0 - left_by_full / np.maximum(left_by_line, 1e-300), 0.0)
    return np.hypot(coefficients[:, 2], coefficients[:, 3]), explained


def scan(time: NDArray, free: NDArray, start: float, settings: ScanSettings,
         signals: dict[str, tuple[NDArray, NDArray | None]]) -> dict[str, Oscillation]:
    """Scan each signal, name -> (residual (n, k), the command it was taken from (n, k') or None), on the uniform
    ``time`` (n,) from ``start`` to the end (module docstring); ``free`` (n,) marks samples outside contact. All
    signals share one fit per window (their columns side by side)."""
    inside = time >= start
    time, weights = time[inside], free[inside].astype(float)
    blocks, slices, known_columns, column = [], {}, {}, 0
    for name, (residual, command) in signals.items():
        own = slice(column, column + residual.shape[1])
        blocks.append(residual[inside])
        column += residual.shape[1]
        known = None
        if command is not None:
            if id(command) not in known_columns:   # one fit for a command several signals were taken from
                known_columns[id(command)] = slice(column, column + command.shape[1])
                blocks.append(command[inside])
                column += command.shape[1]
            known = known_columns[id(command)]
        slices[name] = (own, known)
    values = np.column_stack(blocks)
    step = float(np.median(np.diff(time))) if time.size > 1 else 0.0
    span = float(time[-1] - time[0]) if time.size > 1 else 0.0
    longest = span / settings.min_cycles
    thinned: dict[int, tuple[NDArray, NDArray, NDArray]] = {}
    best: dict[str, Oscillation | None] = {name: None for name in signals}
    closest = {name: Oscillation(False, 0.0, 0.0, 0.0, 0.0, 0, 0.0, longest) for name in signals}
    grid = periods(settings, longest)
    if settings.max_period is not None:
        grid = grid[grid <= settings.max_period * (1.0 + 1e-9)]
    for period in grid:
        stride = max(1, int(period / (settings.samples_per_period * step)))
        if stride not in thinned:
            # Block means, not every stride-th sample: a faster oscillation averages out instead of aliasing into a
            # slow one. A block's weight is its free share.
            blocks = time.size // stride
            thinned[stride] = tuple(array[:blocks * stride].reshape(blocks, stride, *array.shape[1:]).mean(axis=1)
                                    for array in (time, values, weights))
        time_s, values_s, weights_s = thinned[stride]
        samples = min(int(round(settings.cycles_per_window * period / (stride * step))) + 1, time_s.size)
        room = time_s.size - samples
        count = 1 if room <= 0 else max(2, int(np.ceil(room / (0.5 * samples))) + 1)
        starts = np.unique(np.linspace(0, max(room, 0), count).round().astype(int))
        index = starts[:, None] + np.arange(samples)[None, :]
        share = weights_s[index].mean(axis=1)
        index = index[(share >= settings.free_share) & (weights_s[index].sum(axis=1) >= 8)]
        if index.shape[0] == 0:
            continue
        amplitude, explained = _fits(time_s, values_s, weights_s, index, period)
        rows = np.arange(index.shape[0])
        # A span of fewer than two windows of cycles_per_window periods end to end (a long period in a short run:
        # its windows overlap, so they are not independent looks) tells a sinusoid from an aperiodic wander only when
        # the sinusoid explains nearly all of it.
        needed = settings.explained_share if span >= 2.0 * settings.cycles_per_window * period - 1e-9 \
            else settings.explained_share_few_cycles
        for name, (own, known) in slices.items():
            a, e = amplitude[:, own], explained[:, own]
            axis = np.argmax(a * (e > needed), axis=1)
            amplitudes, shares = a[rows, axis], e[rows, axis]
            oscillating = (amplitudes > settings.amplitude) & (shares > needed)
            if known is not None:
                # Per axis: the command's largest amplitude at P on the residual's own axis (the command's columns
                # are one or more (n, k) blocks side by side, e.g. the hand's target and the planner for x_M).
                # A block counts when the command itself repeats at P there (its sinusoid explains as much of it as a
                # residual's must): an aperiodic command makes no periodic answer.
                blocks_amplitude = amplitude[:, known].reshape(len(rows), -1, a.shape[1])[rows, :, axis]
                blocks_share = explained[:, known].reshape(len(rows), -1, a.shape[1])[rows, :, axis]
                forced = np.any((blocks_share > needed) & (amplitudes[:, None] < settings.forced_share
                                                            * blocks_amplitude), axis=1)
                oscillating &= ~forced
            window_share = float(oscillating.mean())
            ratio = float(amplitudes[-1] / amplitudes[0]) if amplitudes[0] > 0.0 else 0.0
            sustained = bool(window_share >= settings.sustained_share and oscillating[-1]
                             and ratio >= settings.decay_ratio and index.shape[0] >= settings.min_windows)
            chosen = oscillating if oscillating.any() else np.ones_like(oscillating)
            found = Oscillation(sustained, float(period), float(amplitudes[chosen].mean()),
                                float(shares[chosen].mean()), window_share, int(index.shape[0]), ratio, longest)
            if sustained and (best[name] is None or found.amplitude > best[name].amplitude):
                best[name] = found
            if not sustained and (window_share, found.amplitude) > (closest[name].window_share,
                                                                    closest[name].amplitude):
                closest[name] = found
    return {name: best[name] if best[name] is not None else closest[name] for name in signals}
