"""The loop's forced answer to its exogenous input, fitted over the run, so that the oscillation scan judges only what
the input does not explain (docs/EXPERIMENTS.md, "The run verdict").

A stable loop driven by an operator and a planner moves about its command by its answer to them: an under-damped
replica (a resonance of gain |H| > 1 at a period P) swings about its command at P whenever the command has power
there, and the swing comes and goes with the command. A self-sustained oscillation does not need the input: it is
there whatever the input does. So the motion minus its command, r(t), is split into

    r(t) = sum over exogenous channels c of  (h_c * u_c)(t - shift_c)  +  a + b t  +  e(t)

by linear least squares over the judged span outside contact, and the scan looks at e(t), what the input does not
explain. Each kernel h_c is causal, ``kernel_length`` long: a direct term plus triangular ("hat") functions every
``kernel_spacing`` seconds, so h_c is piecewise linear in the lag (a finite impulse response with a smooth kernel; an
FIR model, Ljung 1999, "System Identification", ch. 4.2). Per axis, the axis's own input only (a Cartesian impedance
answers mostly along the axis it is moved on): the parameters stay few against the samples, which keeps the fit from
explaining an input-independent oscillation by chance (a regression of p parameters on m samples explains about p/m
of a signal unrelated to its regressors; the fit is refused below ``rows_per_parameter`` samples a parameter).

ONLY EXOGENOUS INPUT. The regressors are what nothing in the loop feeds back into: the planner's motion and the
operator's planned target (the hand's target before the hand's reaction to the force it feels; see
VerdictInput.operator_target), each at the shifts at which it enters the delayed loop (the replica sees the planner
at once and the operator's target one delay later; through a closed force loop each comes back again one round trip
later). Never x_M, x_d or what the replica received: those carry the loop's own oscillation, which a fit on them
would explain away. A model of the exogenous input alone cannot produce an oscillation the input does not drive, so
a limit cycle stays in e(t) (less the p/m share above).

The same kernels give the loop's gain from the operator's planned offset to a motion: the frequency response of its
target channels plus the unit path its reference takes out, |G(f)|. Its peak over ``band_hz`` is the loop's
resonant amplification (an under-damped replica shows |G| > 1), reported so that a forced resonance stays visible
after it is no longer called an oscillation.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class ForcedSettings:
    enabled: bool = True             # False: no fit, the motions are scanned as they are (the rule before the fit)
    kernel_length: float = 3.0       # [s] an under-damped loop's ringing (damping ratio 0.3 at 0.7 Hz) is down to 2 %
    kernel_spacing: float = 0.2      # [s] hats this far apart: kernels resolved to about 2.5 Hz
    fit_period: float = 0.05         # [s] rows of the fit: block means of this length
    rows_per_parameter: float = 3.0  # fewer rows a fold is fitted on than this per parameter: no fit
    folds: int = 4                   # the forced answer of each stretch is predicted from the others' fit
    band_hz: tuple[float, float] = (0.2, 2.0)   # where the gain is reported: the operator's moves and wander
    period_spread: float = 0.15      # a free oscillation's period is searched within this share of the scan's
    period_candidates: int = 61      # ... on this many grid periods (0.5 % apart), then refined between two


@dataclass(frozen=True)
class Channel:
    """One exogenous input: ``series`` (n, k) delayed by ``shift`` seconds; ``unit`` when the motion's reference
    (the command it was taken from) holds it with gain 1, so that the motion's gain to it adds that path back."""

    name: str
    series: NDArray
    shift: float
    unit: bool = False


@dataclass
class ForcedAnswer:
    """The fit of one residual (n, k)."""

    predicted: NDArray                       # (n, k) the forced answer on the whole grid
    explained_share: NDArray                 # (k,) share of the residual's variance over the fitted rows
    rows: int                                # fitted rows (block means)
    parameters: int                          # per axis
    channels: list[str] = field(default_factory=list)
    gain: dict | None = None                 # peak |G| of the motion to the operator's target, its period, the axis

    def as_dict(self) -> dict:
        return dict(explained_share=[round(float(v), 4) for v in self.explained_share], rows=self.rows,
                    parameters=self.parameters, channels=self.channels, gain=self.gain)


def _shifted(time: NDArray, values: NDArray, shift: float) -> NDArray:
    """``values`` at ``time - shift`` (the first value before the series starts)."""
    if shift == 0.0:
        return values
    return np.column_stack([np.interp(time - shift, time, values[:, j]) for j in range(values.shape[1])])


def _regressors(time: NDArray, channels: list[Channel], axis: int, settings: ForcedSettings) -> tuple[NDArray, int]:
    """(n, p) regressors of one axis on the uniform ``time``: per channel its direct term and its hats, then the
    constant and the trend; and the number of hats a channel has."""
    step = float(time[1] - time[0])
    width = max(1, int(round(settings.kernel_spacing / step)))          # a hat's half width in samples
    hats = max(1, int(round(settings.kernel_length / (width * step))))
    triangle = 1.0 - np.abs(np.arange(-width, width + 1)) / width        # the hat centred at 0, on the sample grid
    columns = []
    for channel in channels:
        u = _shifted(time, channel.series, channel.shift)[:, axis]
        columns.append(u)
        # One convolution with the hat, then each hat is that convolution delayed by its centre (b width samples):
        # regressor_b(t) = sum over lags of hat_b(lag) u(t - lag) step.
        padded = np.r_[np.full(width + hats * width, u[0]), u]
        smooth = np.convolve(padded, triangle, mode="full")[width: width + padded.size] * step
        for b in range(1, hats + 1):
            start = hats * width - b * width + width
            columns.append(smooth[start: start + u.size])
    columns += [np.ones_like(time), (time - time[0]) / max(time[-1] - time[0], step)]
    return np.column_stack(columns), hats


def _blocks(values: NDArray, size: int) -> NDArray:
    count = values.shape[0] // size
    return values[:count * size].reshape(count, size, *values.shape[1:]).mean(axis=1)


def free_oscillation_period(time: NDArray, residual: NDArray, channels: list[Channel], use: NDArray, period: float,
                            settings: ForcedSettings | None = None, design: dict | None = None) -> float:
    """The period within +-``settings.period_spread`` of ``period`` at which a free sinusoid fitted JOINTLY with the
    kernels (as ``fit`` fits it) leaves the least of ``residual`` (n, k) over the fitted rows, summed over the axes:
    a grid, then a bounded 1-D minimisation between the best grid point's neighbours.

    Why jointly: where a limit cycle sits at a period where the input moves too (an under-damped loop's resonance),
    kernels fitted alone take part of it, most near the resonance where the input's power is; what they leave then
    has a notch there, and its periodogram peaks off the cycle's period (1.54 s against 1.46 s, 5 % off: the free
    sinusoid, drifting against the cycle, took too little of it and the kernels the rest). Fitted together, the
    sinusoid at the cycle's own period explains it wholly and the kernels only the answer, so the joint fit's
    remainder is least there. By the Frisch-Waugh-Lovell theorem the joint remainder is that of the sinusoid's columns
    regressed on the kernels' remainder, each with the kernels' part taken out (Davidson and MacKinnon 2004,
    "Econometric Theory and Methods", ch. 2.4): one projection per axis, then four columns per candidate period."""
    from scipy.optimize import minimize_scalar

    settings = settings or ForcedSettings()
    design = {} if design is None else design
    if not channels or time.size < 4 or period <= 0.0:
        return period
    step = float(time[1] - time[0])
    size = max(1, int(round(settings.fit_period / step)))
    rows = _blocks(use.astype(float), size) > 1.0 - 1e-9
    if np.count_nonzero(rows) < 8:
        return period
    # The sinusoid's columns at the rows' centres: a block mean of a sinusoid is the sinusoid at the block's centre
    # times one factor common to its columns (and the ramp is linear within a block), which leaves the remainder of
    # a least-squares fit as it is.
    centre = _blocks(time, size)[rows]
    ramp = (centre - time[0]) / max(time[-1] - time[0], step)
    projections = []
    for axis in range(residual.shape[1]):
        if axis not in design:
            full, hats = _regressors(time, channels, axis, settings)
            design[axis] = (full, _blocks(full, size), hats)
        x = design[axis][1][rows]
        x = x / np.maximum(np.sqrt(np.mean(x * x, axis=0)), 1e-12)
        # An orthonormal basis of the kernels' columns (a column of zeros, an axis the input does not move, dropped).
        basis, singular, _ = np.linalg.svd(x, full_matrices=False)
        basis = basis[:, singular > singular[0] * 1e-9]
        y = _blocks(residual[:, axis], size)[rows]
        projections.append((basis, y - basis @ (basis.T @ y)))

    def left(candidates: NDArray) -> NDArray:
        """Sum over the axes of what the joint fit leaves, per candidate period (c,)."""
        phase = 2.0 * np.pi * centre[:, None] / candidates[None, :]                     # (m, c)
        sine, cosine = np.sin(phase), np.cos(phase)
        free = np.stack([sine, cosine, ramp[:, None] * sine, ramp[:, None] * cosine], axis=2)   # (m, c, 4)
        flat = free.reshape(centre.size, -1)
        total = np.zeros(candidates.size)
        for basis, remainder in projections:
            own = (flat - basis @ (basis.T @ flat)).reshape(free.shape)                # the kernels' part out
            gram = np.einsum("mci,mcj->cij", own, own)
            gram += 1e-12 * np.trace(gram, axis1=1, axis2=2)[:, None, None] * np.eye(4)
            moment = np.einsum("mci,m->ci", own, remainder)                               # (c, 4)
            taken = np.einsum("cj,cj->c", moment, np.linalg.solve(gram, moment[..., None])[..., 0])
            total += float(remainder @ remainder) - taken
        return total

    spread = settings.period_spread
    grid = period * np.linspace(1.0 - spread, 1.0 + spread, settings.period_candidates)
    values = left(grid)
    best = int(np.argmin(values))
    low, high = grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)]
    refined = minimize_scalar(lambda p: float(left(np.array([p]))[0]), bounds=(low, high), method="bounded",
                              options=dict(xatol=1e-4 * period))
    return float(refined.x) if refined.success and refined.fun <= values[best] else float(grid[best])


def fit(time: NDArray, residual: NDArray, channels: list[Channel], use: NDArray,
        settings: ForcedSettings | None = None, free_period: float | None = None,
        design: dict | None = None) -> ForcedAnswer | None:
    """The forced answer of ``residual`` (n, k) to ``channels`` on the uniform ``time`` (n,), fitted on the samples
    ``use`` (n,) marks (the judged span outside contact, module docstring). None when the marked span holds fewer
    than ``rows_per_parameter`` rows a parameter.

    ``free_period``: a period at which the residual may hold an oscillation of its own (the one the scan found in the
    residual before the fit). A sinusoid of that period, its amplitude and phase free to drift linearly over the run,
    is fitted beside the kernels and not counted in the forced answer: the kernels then cannot take a free
    oscillation for an answer to the input where the input happens to move at that period.

    ``design``: a dict the caller keeps for one ``time`` and one set of channels (names and shifts), in which the
    regressors are kept between fits (they do not depend on the residual or the free period)."""
    settings = settings or ForcedSettings()
    design = {} if design is None else design
    if not channels or time.size < 4:
        return None
    step = float(time[1] - time[0])
    size = max(1, int(round(settings.fit_period / step)))
    rows = _blocks(use.astype(float), size) > 1.0 - 1e-9                # blocks wholly in use
    predicted = np.zeros_like(residual)
    explained = np.zeros(residual.shape[1])
    parameters, hats = 0, 0
    kernels = []
    for axis in range(residual.shape[1]):
        if axis not in design:
            full, hats = _regressors(time, channels, axis, settings)
            design[axis] = (full, _blocks(full, size), hats)
        regressors, x_all, hats = design[axis]
        forced_columns = regressors.shape[1]
        if free_period is not None and free_period > 0.0:
            phase = 2.0 * np.pi * time / free_period
            ramp = (time - time[0]) / max(time[-1] - time[0], step)
            free = np.column_stack([np.sin(phase), np.cos(phase), ramp * np.sin(phase), ramp * np.cos(phase)])
            regressors = np.column_stack([regressors, free])
            x_all = np.column_stack([x_all, _blocks(free, size)])
        parameters = regressors.shape[1]
        if np.count_nonzero(rows) * (settings.folds - 1) / settings.folds < settings.rows_per_parameter * parameters:
            return None
        y_all = _blocks(residual[:, axis], size)
        x, y = x_all[rows], y_all[rows]
        # Scaled columns (the hats' regressors are a step smaller than the direct terms); least squares by the normal
        # equations, a fold's by taking its rows out of the whole run's (a column of zeros gets a zero coefficient).
        scale = np.maximum(np.sqrt(np.mean(x * x, axis=0)), 1e-12)
        scaled = x / scale
        gram, moment = scaled.T @ scaled, scaled.T @ y
        ridge = 1e-10 * max(float(np.trace(gram)), 1e-300) / parameters * np.eye(parameters)

        def solve(keep: NDArray) -> NDArray:
            out = scaled[~keep]  # noqa: B023
            return np.linalg.solve(gram - out.T @ out + ridge, moment - out.T @ y[~keep]) / scale  # noqa: B023

        # Out of sample: each of ``folds`` contiguous stretches of the run is predicted by the kernels fitted on the
        # others. A linear loop's answer is the same in every stretch, so it is predicted; a fit that explains an
        # input-independent oscillation in the stretches it saw (a kernel playing it after each of the input's moves)
        # predicts nothing in phase with it where it did not look.
        block_time = _blocks(time, size)
        fold_of = np.minimum((np.cumsum(rows) - 1) * settings.folds // max(np.count_nonzero(rows), 1),
                             settings.folds - 1)
        edges = [block_time[rows][fold_of[rows] == k].min() for k in range(settings.folds)] + [np.inf]
        fold_time = np.searchsorted(np.array(edges[1:-1]), time, side="right")
        fold_row = fold_of[rows]
        prediction = np.zeros(time.size)
        left = np.zeros(y.size)
        for k in range(settings.folds):
            coefficients = solve(fold_row != k)[:forced_columns]   # the free sinusoid is not the forced answer
            inside = fold_time == k
            prediction[inside] = regressors[inside, :forced_columns] @ coefficients
            left[fold_row == k] = y[fold_row == k] - x[fold_row == k, :forced_columns] @ coefficients
        # The out-of-sample prediction taken at the least-squares weight it earns, within [0, 1]: 1 for a loop the
        # kernels predict, 0 for one whose residual they do not (an input-independent oscillation), so that a fit
        # that predicts nothing adds nothing to what is scanned.
        guessed = y - left
        weight = float(np.clip(np.dot(y - y.mean(), guessed - guessed.mean())
                               / max(float(np.sum((guessed - guessed.mean()) ** 2)), 1e-300), 0.0, 1.0))
        predicted[:, axis] = weight * prediction
        left = y - weight * guessed
        total = float(np.sum((y - y.mean()) ** 2))
        explained[axis] = 1.0 - float(np.sum((left - left.mean()) ** 2)) / total if total > 1e-300 else 0.0
        kernels.append(solve(np.ones(y.size, dtype=bool))[:forced_columns])
    answer = ForcedAnswer(predicted, explained, int(np.count_nonzero(rows)), parameters,
                          [f"{c.name} {c.shift:g} s" for c in channels])
    answer.gain = _gain(channels, kernels, hats, step, residual, settings)
    return answer


def _gain(channels: list[Channel], kernels: list[NDArray], hats: int, step: float, residual: NDArray,
          settings: ForcedSettings) -> dict | None:
    """Peak over the band of |G(f)|, the motion's gain to the operator's target (module docstring), on the axis along
    which the target moves most; None without a unit target channel."""
    targets = [i for i, c in enumerate(channels) if c.name == "operator target"]
    if not any(channels[i].unit for i in targets):
        return None
    power = [sum(float(np.var(channels[i].series[:, axis])) for i in targets) for axis in range(residual.shape[1])]
    axis = int(np.argmax(power))
    width = max(1, int(round(settings.kernel_spacing / step)))
    frequencies = np.linspace(settings.band_hz[0], settings.band_hz[1], 181)
    omega = 2.0 * np.pi * frequencies
    lags = np.arange(1, hats + 1) * width * step                         # the hats' centres
    # A hat of half width w centred at c: its transform is w sinc^2(f w) e^(-j w c) (w in seconds).
    half = width * step
    hat = half * np.sinc(frequencies * half) ** 2
    total = np.zeros(frequencies.size, dtype=complex)
    per_channel = 1 + hats
    for i in targets:
        c = channels[i]
        block = kernels[axis][i * per_channel:(i + 1) * per_channel]
        response = block[0] + hat * (np.exp(-1j * np.outer(omega, lags)) @ block[1:])
        total += (response + (1.0 if c.unit else 0.0)) * np.exp(-1j * omega * c.shift)
    magnitude = np.abs(total)
    peak = int(np.argmax(magnitude))
    return dict(peak_gain=round(float(magnitude[peak]), 3), period_s=round(float(1.0 / frequencies[peak]), 3),
                axis="xyz"[axis] if residual.shape[1] == 3 else axis,
                band_hz=list(settings.band_hz))
