"""Per-axis wear trend: change points, outliers, growth models, forecast of the threshold crossing.

Input: the axis's estimates in time order. Only estimates that are ``ok`` and excited enter,
and of those the converged ones and the unconverged ones with a stated uncertainty (weighted
by it; :func:`usable`). An unexcited recording never enters a trend. Steps (numbers in
docs/assumptions.md, "Wear tracking"):

1. **Noise scale** σ̂: the MAD of second differences / √6 (insensitive to a trend and to
   isolated jumps), floored at :data:`SIGMA_FLOOR`. The second differences are divided
   differences in time, scaled to the noise of an equally spaced triple
   (:func:`_second_differences`): recordings at varying times of day made the plain
   second differences of a fast linear trend read as noise. A jump enters two second differences, half
   of them on a series of six: there σ̂ grows with the jump and hides it (3 + 3 estimates
   around a 5 mrad jump: σ̂ 1.5 mrad, the limit 8σ̂ above the jump, and a line through the step
   forecast the crossing at day 107 [75, 216] for a true ≈ 1500). When step 2 finds no jump with
   σ̂, it searches once more with the scale of the series with its largest step taken out
   (:func:`jump_scale`); the jump must pass the same rule, and σ̂ becomes that scale.
2. **Change points** (sudden damage or maintenance): ``ruptures.Pelt`` with a piecewise-linear
   cost proposes breaks (penalty :data:`PEN_FACTOR`·ln n·σ̂²); a break is kept only if the first
   two recordings after it both lie more than J_min = max(:data:`JUMP_SIGMA`·σ̂,
   :data:`JUMP_MIN`, :data:`JUMP_STEPS` × the median change between recordings before it)
   from the local trend of up to :data:`JUMP_PRE` recordings before it
   (quadratic from 5 points on), on the same side — or, as a level shift, beyond
   max(:data:`JUMP_SIGMA`·σ̂, :data:`JUMP_MIN`, :data:`JUMP_WEAR_FRAC` × the wear the trend
   predicts to each) and agreeing within :data:`JUMP_LEVEL_TOL` (weekly data: the change
   between recordings is a week of wear) — so a jump is flagged on its second
   recording, a lone outlier never. That trend needs three recordings that agree; an outlier
   among them leaves it first (:func:`_window_inliers`): a wild estimate as the last before a
   break bent the trend, and the normal recordings after it read as a jump (a 10 mrad outlier
   on a 40-recording line, at every position × 20 seeds: a false jump of ≈ −5 mrad in 337 of
   780 cases).
3. **Outliers**: residual from a robust local quadratic (Huber M-estimate by IRLS) through
   the 8 nearest recordings in the segment (±4, one-sided at its ends), the point itself left out; |r| >
   max(:data:`OUTLIER_SIGMA`·σ̂, :data:`OUTLIER_FLOOR`, :data:`OUTLIER_STEPS` × local wear step)
   is an outlier and leaves the fit (one at a time, the farthest first; then each one left out
   is judged again against the inliers alone and rejoins within its limit). The latest
   recordings left out this way rejoin when the growth model of step 4, fitted without them,
   predicts them within the same limit: a one-sided local quadratic at the end of the series
   lags wear that accelerates, so a correct latest estimate looked like an outlier; a jump or a
   bad recording stays out. When no model can be fitted without them, or at least two latest
   recordings are out, they rejoin if the model fitted with them passes every used estimate
   within its limit.
4. **Growth models** on the inliers, with one level-shift term per change point and weights
   1/σ_i² when the estimator gives uncertainties (else equal; the scale is estimated):
   *linear* δ = a + b t (``statsmodels`` WLS) and *accelerating* δ = a + v (e^{kt} − 1)/k,
   k ≥ 0 (nested: k → 0 is linear; ``scipy.optimize.least_squares``). After a negative
   change point (repair) with :data:`MIN_OWN_RATE_POINTS` inliers after it, the linear model
   gets a slope-change term there (the new part's own rate), taken by AICc as below. The accelerating model is
   chosen only when its AICc is lower by more than :data:`AICC_MARGIN` (Burnham & Anderson's
   "substantial support").
5. **Forecast**: the fitted mean crosses the threshold at t*; the 90 % interval of t* comes from
   inverting the pointwise 90 % band of the true δ (the upper band's crossing is the early
   bound, the lower band's the late one; never = ∞). That band is the fit's confidence band of
   the mean widened by the axis's **systematic uncertainty** σ_sys (:func:`systematic_std`):
   the part of the estimator's stated uncertainty that the scatter between recordings does
   not show is the same on every recording of the axis (same drive, encoder, δ1), so it does
   not average out with more recordings and the fit's band alone would be far too narrow.
   Prediction bands for a new estimate (the fit's mean band widened by the residual scale;
   the axis's systematic error is shared by its next estimate) are drawn in the plots.
6. **Monotone trend** for display: isotonic regression (scikit-learn) per segment, fitted to
   the inliers (an outlier gets the line's value at its time).

**Linear axes.** The absolute constants below are in rad, set on rotary fleets (gaps 70–200
mrad, 40 mrad or more of wear to the threshold, jumps of 10–20 mrad). A linear (prismatic)
axis's δ is a length in m, its lost motion 5–60 µm: its series runs through the same rules in
units of :data:`LINEAR_SCALE` m per rad (:func:`trend_scale`; :func:`fit_trend` divides δ̂, σ_i
and the threshold by it and multiplies the results back), so each constant keeps its ratio to the
wear a threshold allows — 2 mrad of jump is 0.5 µm, the 20 µrad noise floor 5 nm. In m they
read as rad (2 mm of jump, a 20 µm noise floor, 5 mm admission: session 34 tester G, G5/G2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from datetime import datetime, timedelta
from typing import Any

import numpy as np

from drivelash.wear.words import count

__all__ = [
    "AxisTrend",
    "ChangePoint",
    "Forecast",
    "analyse",
    "fit_trend",
    "systematic_std",
    "trend_scale",
    "usable",
]

#: Lower bound of the noise scale σ̂ [rad] (estimates agree better than the encoder model).
SIGMA_FLOOR = 2e-5
#: Change-point search penalty: PEN_FACTOR · ln(n) · σ̂².
PEN_FACTOR = 6.0
#: A jump must exceed JUMP_SIGMA · σ̂ …
JUMP_SIGMA = 8.0
#: … and JUMP_MIN [rad] (2 mrad: below it a jump is not "sudden damage" for maintenance).
JUMP_MIN = 2e-3
#: … and JUMP_STEPS times the median change between consecutive recordings before it
#: (fast but smooth wear is not a jump) …
JUMP_STEPS = 3.0
#: … or (session 30, B-03: on weekly data 3 × the change between recordings is three weeks of
#: wear and hid a 15–20 mrad jump) a level shift: both residuals beyond JUMP_WEAR_FRAC × the
#: wear the reference predicts to each (median rate × time since its last recording) …
JUMP_WEAR_FRAC = 0.5
#: … that agree within JUMP_LEVEL_TOL × the smaller (a jump's step stays; the extrapolation
#: error of smooth acceleration grows with the horizon, ≈ 4× from one interval to two).
JUMP_LEVEL_TOL = 0.25
#: Recordings before a break whose linear trend is the jump's reference.
JUMP_PRE = 10
#: Outlier rule: |residual from the running median| > max(OUTLIER_SIGMA · σ̂, OUTLIER_FLOOR).
OUTLIER_SIGMA = 6.0
OUTLIER_FLOOR = 0.5e-3
#: … and > OUTLIER_STEPS × the local wear step (median change between neighbouring recordings):
#: on fast wear the local extrapolation error grows with the step.
OUTLIER_STEPS = 0.5
#: The accelerating model needs an AICc lower by more than this.
AICC_MARGIN = 2.0
#: Fewest inliers after a repair (a negative change point) for the new part's own wear rate
#: (a slope-change term, chosen by AICc): three, the fewest whose line can show its scatter.
MIN_OWN_RATE_POINTS = 3
#: Two-sided level of the forecast interval and bands.
LEVEL = 0.90
#: Fewest inliers for a forecast.
MIN_POINTS = 5
#: An excited estimate the estimator did not call converged enters the trend (weighted by 1/σ²)
#: when its stated 95 % uncertainty 1.96·σ is at most this [rad]: 2.5× the estimator's 2 mrad
#: claim, 1/8 of the smallest wear-to-threshold gap of the simulated fleets (40 mrad). The
#: noise scale, change-point search and outlier test are unweighted, so a far less certain
#: estimate (one of 260 mrad was seen) must stay out.
UNCONVERGED_MAX_U95 = 5e-3
#: How far after the latest inlier the trend may be judged "now" at a later estimate the fit
#: left out although that estimate lies below the fitted mean by more than its outlier limit:
#: this many median intervals between the inliers (:func:`judged_at`). 2: one skipped
#: recording still counts as the usual spacing; a month after daily recordings does not.
JUDGE_REACH_STEPS = 2.0
#: Longest forecast look-ahead, in multiples of the data span (and at least 365 days).
LOOKAHEAD_SPANS = 20.0
#: Metres of a linear axis's lost motion per rad of a rotary axis's in the constants above
#: (:func:`trend_scale`; docs/assumptions.md, "Wear tracking"): the wear a threshold allows, about
#: 10 µm on a linear axis (5–60 µm of lost motion, e.g. 20 → 30 µm) against the 40 mrad the
#: constants were set for — 0.25 µm per mrad: jumps from 0.5 µm, noise floor 5 nm, unconverged
#: estimates admitted up to ±1.25 µm (95 %).
LINEAR_SCALE = 2.5e-4


def trend_scale(kind: str | None) -> float:
    """SI units of an axis's δ per rad of the trend's constants: 1 on a rotary axis (δ in rad),
    :data:`LINEAR_SCALE` on a linear one (``kind`` "prismatic", δ in m).

    Parameters
    ----------
    kind : str or None
        The axis's kind (``AxisSpec.kind``, the store's ``axis.kind``); None: rotary.
    """
    return LINEAR_SCALE if kind == "prismatic" else 1.0


@dataclass(frozen=True)
class ChangePoint:
    """A detected jump: at recording ``index`` (of the used series), size [rad]."""

    index: int
    t_days: float
    size: float


@dataclass
class Forecast:
    """Threshold crossing of the fitted mean, in days since the axis's first used estimate.

    ``t_cross`` is None when the mean never reaches the threshold within the look-ahead;
    ``t_late`` is ``inf`` when the lower band never does.
    """

    t_cross: float | None
    t_early: float | None
    t_late: float | None
    crossed: bool


@dataclass
class AxisTrend:
    """Everything the trend analysis found for one axis (times in days since ``t0``).

    ``sigma`` is the noise scale σ̂ between recordings [rad], ``sigma_sys`` the systematic
    (non-averaging) standard uncertainty of the axis's estimates [rad] that widens the band of
    the true δ and the forecast interval (:func:`systematic_std`).
    """

    t0: datetime | None
    t: np.ndarray
    y: np.ndarray
    inlier: np.ndarray
    change_points: list[ChangePoint]
    sigma: float
    model: str | None
    params: dict[str, float]
    aicc: dict[str, float]
    forecast: Forecast | None
    threshold: float | None
    isotonic: np.ndarray
    sigma_sys: float = 0.0
    #: Days at which the trend is judged "now" (the fitted δ now, the crossed verdict, the days
    #: left): the latest inlier, or a later estimate the fit left out when that estimate lies at
    #: or above the fitted mean at its time (:func:`judged_at`); None without a fit.
    t_now: float | None = None
    _curve: Any = field(default=None, repr=False)
    #: Why no growth model was fitted although there were enough inliers (None otherwise): their
    #: times do not determine it — all at one start time (a batch export named with the export
    #: time, a coarse clock) or, with jumps, too few distinct times (:func:`_fit_linear`).
    unfitted: str | None = None

    def curve(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(mean, lower, upper, pred_lower, pred_upper) of the fitted model at days ``t`` [rad].

        ``lower``/``upper``: the 90 % band of the true δ (the fit's confidence band of the mean
        widened by ``sigma_sys``); ``pred_*``: the 90 % prediction band of a new estimate.
        """
        if self._curve is None:
            nan = np.full(np.shape(t), np.nan)
            return nan, nan, nan, nan, nan
        return self._curve(np.asarray(t, dtype=float))

    def to_time(self, days: float | None) -> datetime | None:
        """Days since ``t0`` as a datetime (None for None or ∞)."""
        if days is None or self.t0 is None or not math.isfinite(days):
            return None
        return self.t0 + timedelta(days=float(days))


# ------------------------------------------------------------------------------- noise, jumps
def _equally_spaced(t: np.ndarray | None) -> bool:
    """Whether times ``t`` [days] are equally spaced (within float rounding: 1e-12 of the
    span), or not increasing — then the time-aware forms fall back to the plain ones."""
    if t is None or np.size(t) < 3:
        return True
    dt = np.diff(np.asarray(t, dtype=float))
    if np.any(dt <= 0):
        return True
    return bool(np.allclose(dt, dt[0], rtol=0.0, atol=1e-12 * max(1.0, float(np.ptp(t)))))


def _second_differences(y: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
    """Second differences of ``y`` [rad], time-aware: each triple's second divided difference
    y[t_{i-1}, t_i, t_{i+1}] scaled to the noise of an equally spaced triple (var = 6σ² for white
    noise σ, as ``numpy.diff(y, 2)``). A linear trend cancels whatever the spacing; with
    ``t`` None or equally spaced it equals ``numpy.diff(y, 2)`` (within float rounding).
    Recordings at varying times of day gave second differences of the trend itself with the
    plain ``numpy.diff`` (session 30, B-05)."""
    if y.size < 3 or _equally_spaced(t):
        return np.diff(y, 2)  # the plain second difference, bit for bit as before
    t = np.asarray(t, dtype=float)
    h0, h1 = np.diff(t)[:-1], np.diff(t)[1:]
    # divided difference = c0·y0 + c1·y1 + c2·y2; its noise is σ·‖c‖, so √6·(c·y)/‖c‖ has the
    # noise of an equally spaced triple's y0 − 2y1 + y2
    c0 = 1.0 / (h0 * (h0 + h1))
    c1 = -1.0 / (h0 * h1)
    c2 = 1.0 / (h1 * (h0 + h1))
    dd = c0 * y[:-2] + c1 * y[1:-1] + c2 * y[2:]
    return math.sqrt(6.0) * dd / np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)


def noise_scale(y: np.ndarray, t: np.ndarray | None = None) -> float:
    """Robust noise σ̂ [rad]: 1.4826 · MAD(Δ²y) / √6, floored at :data:`SIGMA_FLOOR`.

    Parameters
    ----------
    y : numpy.ndarray
        δ̂ [rad], in time order.
    t : numpy.ndarray, optional
        Times [days]; when given, Δ²y are second divided differences scaled to an equally
        spaced triple (:func:`_second_differences`), so uneven recording times do not read as
        noise. None: equally spaced.
    """
    if y.size < 4:
        return SIGMA_FLOOR
    d2 = _second_differences(y, t)
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return max(1.4826 * mad / math.sqrt(6.0), SIGMA_FLOOR)


def jump_scale(y: np.ndarray, t: np.ndarray | None = None) -> float:
    """Noise scale [rad] of ``y`` with its largest step taken out: the step Δy_m farthest from
    the median step is replaced by that median (the later samples shift by the difference),
    then :func:`noise_scale`. Without a jump it is :func:`noise_scale` of a series one step
    quieter; with one, the scale the jump would otherwise inflate. With times ``t`` [days] the
    steps are judged as rates: Δy_m farthest from the median rate × Δt_m is replaced by that."""
    if y.size < 4:
        return SIGMA_FLOOR
    d = np.diff(y)
    if _equally_spaced(t):
        med = np.full(d.size, float(np.median(d)))
    else:
        dt = np.diff(np.asarray(t, dtype=float))
        med = float(np.median(d / dt)) * dt
    m = int(np.argmax(np.abs(d - med)))
    y2 = np.array(y, dtype=float)
    y2[m + 1 :] -= d[m] - med[m]
    return noise_scale(y2, t)


def _huber_poly(x: np.ndarray, y: np.ndarray, deg: int, iters: int = 6) -> np.ndarray:
    """Robust polynomial fit (Huber M-estimate, c = 1.345, MAD scale, by IRLS — the estimator of
    ``statsmodels`` ``RLM(..., HuberT())``, written out because it runs per recording).
    Returns the coefficients, highest power first (``numpy.polyval`` order)."""
    X = np.vander(x, deg + 1)
    w = np.ones_like(y)
    for k in range(iters + 1):
        A = X.T @ (w[:, None] * X)
        try:
            beta = np.linalg.solve(A, X.T @ (w * y))
        except np.linalg.LinAlgError:
            beta = np.linalg.lstsq(X * np.sqrt(w)[:, None], y * np.sqrt(w), rcond=None)[0]
        if k == iters:
            break
        r = y - X @ beta
        s = 1.4826 * float(np.median(np.abs(r)))
        if not s > 0:
            break
        a = np.abs(r) / (1.345 * s)
        w = np.minimum(1.0, 1.0 / np.maximum(a, 1e-300))
    return beta


def _local_fit(t: np.ndarray, y: np.ndarray) -> np.poly1d:
    """Local trend before a candidate break (robust): quadratic from 5 points on (smooth
    acceleration must not look like a jump), linear below."""
    deg = 2 if t.size >= 5 else 1  # a reference has three or more (:func:`_window_inliers`)
    return np.poly1d(_huber_poly(t - t[-1], y, deg))


def detect_jumps(t: np.ndarray, y: np.ndarray, sigma: float | None = None) -> list[ChangePoint]:
    """Change points of a δ̂ series (see the module docstring, steps 1–2).

    Parameters
    ----------
    t : numpy.ndarray
        Days, increasing.
    y : numpy.ndarray
        δ̂ [rad].
    sigma : float, optional
        Noise scale [rad]; default: :func:`noise_scale`, and when that finds no jump, once more
        :func:`jump_scale` (:func:`jumps_and_scale`).
    """
    if sigma is None:
        return jumps_and_scale(t, y)[0]
    return _search_jumps(t, y, sigma)


def jumps_and_scale(t: np.ndarray, y: np.ndarray) -> tuple[list[ChangePoint], float]:
    """Change points and the noise scale σ̂ [rad] they were found with (module docstring, steps
    1–2): :func:`noise_scale`; when no jump passes with it, the search once more with
    :func:`jump_scale` if that is smaller — σ̂ is then that scale if a jump passes."""
    sigma = noise_scale(y, t)
    if y.size < 4:
        return [], sigma
    cps = _search_jumps(t, y, sigma)
    if not cps:
        s2 = jump_scale(y, t)
        if s2 < sigma:
            cps = _search_jumps(t, y, s2)
            if cps:
                sigma = s2
    return cps, sigma


def _window_inliers(t: np.ndarray, y: np.ndarray, s: float) -> np.ndarray | None:
    """Inliers of the recordings before a candidate break, or None when they make no reference.

    One at a time, while four or more are left: the recording whose removal leaves the others
    closest to their own polynomial (least squares; quadratic when five or more are left, as
    the trend itself, else a line — least trimmed squares with one left out) leaves if it lies
    beyond step 3's limit from that polynomial. Three are judged each against the line through
    the other two; three that do not agree are no reference (which of them is wild cannot be
    told), and neither are two (a wild one cannot be seen: a line through a normal and a wild
    recording made the steady wear after them a "jump").

    Step 3's local rule (:func:`_outliers`) is not used here: at the end of a short window a
    line through four neighbours that holds the wild estimate extrapolates as far from the
    normal recording after it, and the normal one left.
    """
    m = y.size
    if m < 3:
        return None
    keep = np.ones(m, dtype=bool)
    floor = max(OUTLIER_SIGMA * s, OUTLIER_FLOOR)

    def limit(o: np.ndarray) -> float:
        return max(floor, OUTLIER_STEPS * float(np.median(np.abs(np.diff(y[o])))))

    while True:
        idx = np.flatnonzero(keep)
        if idx.size == 3:
            for i in idx:
                o = idx[idx != i]
                beta = np.polyfit(t[o] - t[i], y[o], 1)
                if abs(y[i] - beta[-1]) > limit(o):
                    return None
            return keep
        best = (math.inf, -1, 0.0)
        for i in idx:
            o = idx[idx != i]
            beta = np.polyfit(t[o] - t[i], y[o], 2 if idx.size >= 5 else 1)
            rms = float(np.sqrt(np.mean((y[o] - np.polyval(beta, t[o] - t[i])) ** 2)))
            if rms < best[0]:
                best = (rms, int(i), abs(y[i] - beta[-1]) / limit(o))
        if best[2] <= 1.0:
            return keep
        keep[best[1]] = False


def _search_jumps(t: np.ndarray, y: np.ndarray, s: float) -> list[ChangePoint]:
    """Step 2 with the noise scale ``s`` [rad]."""
    import ruptures as rpt

    n = y.size
    if n < 4:
        return []
    signal = np.column_stack([y, np.ones(n), t - t[0]])
    algo = rpt.Pelt(model="linear", min_size=2, jump=1).fit(signal)
    bkps = [b for b in algo.predict(pen=PEN_FACTOR * math.log(n) * s * s) if 0 < b < n]
    j_min = max(JUMP_SIGMA * s, JUMP_MIN)
    found: list[ChangePoint] = []
    last = 0
    for b in sorted(bkps):
        lo = max(last, b - JUMP_PRE)
        # the reference: the trend of the recordings before the break without their outliers
        keep = _window_inliers(t[lo:b], y[lo:b], s)
        if keep is None:
            continue
        tw, yw = t[lo:b][keep], y[lo:b][keep]
        ref = _local_fit(tw, yw)
        post = y[b : b + 2] - ref(t[b : b + 2] - tw[-1])
        # the recent wear increment per recording: a jump is sudden against it
        step = float(np.median(np.abs(np.diff(yw))))  # a reference has three or more
        j_b = max(j_min, JUMP_STEPS * step)
        # … or, a level shift against the wear the reference predicts over the time to each
        # recording judged (JUMP_WEAR_FRAC × median rate × that time): on weekly data the
        # change between recordings is a week of wear and 3× it hid a 15–20 mrad jump (B-03).
        # Then the two residuals must agree (JUMP_LEVEL_TOL): the extrapolation error of smooth
        # acceleration grows with the horizon, a jump's step stays.
        rate = max(float(np.median(np.abs(np.diff(yw)) / np.diff(tw))), abs(float(ref.deriv()(0.0))))
        j_t = np.maximum(j_min, JUMP_WEAR_FRAC * rate * (t[b : b + 2] - tw[-1]))
        if post.size < 2 or np.sign(post[0]) != np.sign(post[1]):
            continue
        by_step = bool(np.all(np.abs(post) > j_b))
        by_level = bool(
            np.all(np.abs(post) > j_t)
            and abs(post[1] - post[0]) <= JUMP_LEVEL_TOL * float(np.min(np.abs(post)))
        )
        if not (by_step or by_level):
            continue
        if not by_step:
            j_b = float(j_t[0])
        # recordings just before the break that the reference left out and that lie beyond the
        # limit on the jump's side are the jump's first: with a scale near the noise floor, Pelt
        # splits 3 + 3 estimates into 2 + 2 + 2 exact lines and proposes the break one late
        while b - 1 > lo and not keep[b - 1 - lo]:
            d = y[b - 1] - ref(t[b - 1] - tw[-1])
            if not (abs(d) > j_b and np.sign(d) == np.sign(post[0])):
                break
            b -= 1
        tail = y[b : b + 5] - ref(t[b : b + 5] - tw[-1])
        found.append(ChangePoint(index=int(b), t_days=float(t[b]), size=float(np.median(tail))))
        last = b
    return found


# ------------------------------------------------------------------------------- models
def _steps(t: np.ndarray, cps: list[ChangePoint]) -> np.ndarray:
    return (
        np.column_stack([(t >= c.t_days - 1e-9).astype(float) for c in cps]) if cps else np.zeros((t.size, 0))
    )


def _expm1_over_k(k: float, t: np.ndarray) -> np.ndarray:
    """(e^{kt} − 1)/k, continuous at k = 0 (→ t)."""
    if abs(k) < 1e-12:
        return t.copy()
    # far in the look-ahead of a fast-accelerating fit e^{kt} overflows: +inf is the right value
    # (the crossing lies before it) and no RuntimeWarning for the API user
    with np.errstate(over="ignore"):
        return np.expm1(k * t) / k


def _d_dk(k: float, t: np.ndarray) -> np.ndarray:
    """∂/∂k of (e^{kt} − 1)/k (→ t²/2 at k = 0)."""
    if abs(k) < 1e-9:
        return 0.5 * t * t
    # overflow far in the look-ahead gives inf or NaN (inf − inf) there, past the crossing
    with np.errstate(over="ignore", invalid="ignore"):
        return (t * np.exp(k * t) * k - np.expm1(k * t)) / (k * k)


def _aicc(rss: float, n: int, p: int) -> float:
    if n - p - 1 <= 0 or rss <= 0:
        return math.inf if rss > 0 else -math.inf
    return n * math.log(rss / n) + 2 * p + 2 * p * (p + 1) / (n - p - 1)


@dataclass
class _Fit:
    name: str
    params: dict[str, float]
    rss: float
    aicc: float
    curve: Any


def _ramp(t: np.ndarray, t_c: float | None) -> np.ndarray:
    """Columns of the new part's own wear rate: (t − t_c) from the change point t_c on [days];
    none when ``t_c`` is None."""
    if t_c is None:
        return np.zeros((t.size, 0))
    return (np.maximum(t - t_c, 0.0) * (t >= t_c - 1e-9))[:, None]


def _fit_linear(
    t: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    cps: list[ChangePoint],
    s_sys: float = 0.0,
    t_own: float | None = None,
) -> _Fit | None:
    """Linear growth δ = a + b t + Σ J_i·1[t ≥ t_i]; with ``t_own`` [days] (the last repair)
    + b1·(t − t_own)₊: the part fitted after it wears at its own rate b + b1. None when the
    times do not determine these terms (a rank-deficient design: all at one time)."""
    import statsmodels.api as sm
    from scipy.stats import t as student

    X = np.column_stack([np.ones_like(t), t, _steps(t, cps), _ramp(t, t_own)])
    if np.linalg.matrix_rank(np.sqrt(w)[:, None] * X) < X.shape[1]:
        # the times do not determine the model (all at one time; a jump between two times):
        # statsmodels would print its SingularMatrixWarning and return a minimum-norm "fit"
        # (slope 0, labelled linear) — no model (session 32 tester F, F2)
        return None
    res = sm.WLS(y, X, weights=w).fit()
    n, p = y.size, X.shape[1]
    rss = float(np.sum(w * res.resid**2))
    scale = float(res.scale)

    q = float(student.ppf(0.5 + LEVEL / 2, max(n - p, 1)))

    def curve(tt: np.ndarray):
        Xn = np.column_stack([np.ones_like(tt), tt, _steps(tt, cps), _ramp(tt, t_own)])
        pr = res.get_prediction(Xn)
        mean = pr.predicted_mean
        half = q * np.sqrt(pr.var_pred_mean + s_sys * s_sys)
        halfp = q * np.sqrt(pr.var_pred_mean + scale / np.mean(w))
        return mean, mean - half, mean + half, mean - halfp, mean + halfp

    params = {"a": float(res.params[0]), "b": float(res.params[1])}
    params.update({f"J{i}": float(v) for i, v in enumerate(res.params[2 : 2 + len(cps)])})
    if t_own is not None:
        params["b1"] = float(res.params[-1])
    return _Fit("linear", params, rss, _aicc(rss, n, p), curve)


def _fit_accelerating(
    t: np.ndarray, y: np.ndarray, w: np.ndarray, cps: list[ChangePoint], lin: _Fit, s_sys: float = 0.0
) -> _Fit | None:
    from scipy.optimize import least_squares
    from scipy.stats import t as student

    span = float(t[-1] - t[0]) if t.size > 1 else 1.0
    if span <= 0:
        return None
    S = _steps(t, cps)
    sw = np.sqrt(w)
    nj = S.shape[1]

    def model(p: np.ndarray, tt: np.ndarray, SS: np.ndarray) -> np.ndarray:
        a, v, k = p[0], p[1], p[2]
        return a + v * _expm1_over_k(k, tt) + (SS @ p[3:] if nj else 0.0)

    def jac(p: np.ndarray, tt: np.ndarray, SS: np.ndarray) -> np.ndarray:
        v, k = p[1], p[2]
        cols = [np.ones_like(tt), _expm1_over_k(k, tt), v * _d_dk(k, tt)]
        return np.column_stack([*cols, SS]) if nj else np.column_stack(cols)

    best = None
    b0 = max(lin.params["b"], 1e-12)
    J0 = [lin.params.get(f"J{i}", 0.0) for i in range(nj)]
    for k0 in (0.3 / span, 1.0 / span, 3.0 / span):
        p0 = np.array([lin.params["a"], b0, k0, *J0])
        lb = np.array([-np.inf, 0.0, 0.0] + [-np.inf] * nj)
        ub = np.array([np.inf, np.inf, 50.0 / span] + [np.inf] * nj)
        try:
            r = least_squares(
                lambda p: sw * (model(p, t, S) - y),
                p0,
                jac=lambda p: sw[:, None] * jac(p, t, S),
                bounds=(lb, ub),
                x_scale="jac",
                max_nfev=400,
            )
        except (ValueError, FloatingPointError):
            continue
        if best is None or r.cost < best.cost:
            best = r
    if best is None:
        return None
    p = best.x
    n, q = y.size, p.size
    rss = float(2.0 * best.cost)
    dof = max(n - q, 1)
    s2 = rss / dof
    Jm = sw[:, None] * jac(p, t, S)
    try:
        cov = s2 * np.linalg.pinv(Jm.T @ Jm)
    except np.linalg.LinAlgError:
        return None
    tq = float(student.ppf(0.5 + LEVEL / 2, dof))
    wbar = float(np.mean(w))

    def curve(tt: np.ndarray):
        SS = _steps(tt, cps)
        mean = model(p, tt, SS)
        G = jac(p, tt, SS)
        var = np.einsum("ij,jk,ik->i", G, cov, G)
        half = tq * np.sqrt(np.maximum(var, 0.0) + s_sys * s_sys)
        halfp = tq * np.sqrt(np.maximum(var, 0.0) + s2 / wbar)
        return mean, mean - half, mean + half, mean - halfp, mean + halfp

    params = {"a": float(p[0]), "v": float(p[1]), "k": float(p[2])}
    params.update({f"J{i}": float(v) for i, v in enumerate(p[3:])})
    return _Fit("accelerating", params, rss, _aicc(rss, n, q), curve)


def _first_crossing(tt: np.ndarray, f: np.ndarray, thr: float) -> float | None:
    above = f >= thr
    if not above.any():
        return None
    i = int(np.argmax(above))
    if i == 0:
        return float(tt[0])
    f0, f1 = f[i - 1], f[i]
    return float(tt[i - 1] + (thr - f0) * (tt[i] - tt[i - 1]) / (f1 - f0)) if f1 != f0 else float(tt[i])


def systematic_std(std: np.ndarray, sigma: float) -> float:
    """Systematic (non-averaging) standard uncertainty of an axis's estimates [rad].

    σ_sys = √max(median(σ_i²) − σ̂², 0): the part of the estimator's stated uncertainty σ_i
    (``delta_std``) that the scatter between recordings σ̂ does not show. The estimator's
    uncertainty is mostly made of parts that are the same on every recording of one axis (its
    resolution floor of 0.1 θ_def, the δ1 check, the stiffness-model part; only the spread of δ̂
    within a run is random), so this part does not average out over recordings: the fit's
    confidence band shrinks as 1/√n, the error of the axis's estimates does not. The random
    part of σ_i is at most σ̂ (otherwise the scatter would show it), so σ_sys is the least
    systematic part the stated uncertainty implies.

    Parameters
    ----------
    std : numpy.ndarray
        The estimator's standard uncertainty of each used estimate [rad]; NaN = unknown.
    sigma : float
        Noise scale between recordings [rad] (:func:`noise_scale`).

    Returns
    -------
    float
        σ_sys [rad]; 0 when no estimate has an uncertainty.
    """
    s = np.asarray(std, dtype=float)
    s = s[np.isfinite(s) & (s > 0)]
    if not s.size:
        return 0.0
    return float(math.sqrt(max(float(np.median(s * s)) - sigma * sigma, 0.0)))


def _isotonic(
    t: np.ndarray, y: np.ndarray, w: np.ndarray, cps: list[ChangePoint], keep: np.ndarray | None = None
) -> np.ndarray:
    """Monotone (isotonic) trend per segment [rad] at every ``t``, fitted to the estimates in
    ``keep`` (default all; :func:`fit_trend` passes the inliers, so the line does not pass
    through estimates the fit left out, B-07); the others get its value at their time."""
    from sklearn.isotonic import IsotonicRegression

    ok = np.ones(y.size, dtype=bool) if keep is None else np.asarray(keep, dtype=bool)
    out = np.array(y, dtype=float)
    edges = [0, *[c.index for c in cps], y.size]
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        m = ok[a:b]
        if m.any():
            iso = IsotonicRegression(increasing=True, out_of_bounds="clip")
            iso.fit(t[a:b][m], y[a:b][m], sample_weight=w[a:b][m])
            out[a:b] = iso.predict(t[a:b])
    return out


def _local_resid(
    t: np.ndarray,
    y: np.ndarray,
    cps: list[ChangePoint],
    half: int = 4,
    keep: np.ndarray | None = None,
    unjudged: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Residual of each estimate from its neighbours: a robust (Huber) local quadratic through
    the 2·``half`` nearest recordings of its segment (±``half`` inside, one-sided at a segment's
    end, so the latest recording is judged by a quadratic too), the point itself left out —
    unbiased on accelerating wear and at a segment's end, not pulled by one outlier. Also
    returns the median change between consecutive neighbours (the local wear step).
    ``keep``: the recordings that may serve as neighbours (default all; outliers already
    found are left out of the others' fits, :func:`_outliers`); ``unjudged``: the residual of
    an estimate with fewer than four neighbours (0: never an outlier)."""
    r = np.full_like(y, unjudged)
    step = np.zeros_like(y)
    edges = [0, *[c.index for c in cps], y.size]
    ok = np.ones(y.size, dtype=bool) if keep is None else keep
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        nb = [j for j in range(a, b) if ok[j]]
        for i in range(a, b):
            cand = [j for j in nb if j != i]
            # the 2·half neighbours nearest in order: ±half inside, one-sided at an end
            pos = int(np.searchsorted(cand, i))
            lo = min(max(0, pos - half), max(0, len(cand) - 2 * half))
            idx = cand[lo : lo + 2 * half]
            if len(idx) < 4:
                continue
            step[i] = float(np.median(np.abs(np.diff(y[idx]))))
            beta = _huber_poly(t[idx] - t[i], y[idx], 2 if len(idx) >= 6 else 1)
            r[i] = y[i] - float(beta[-1])
    return r, step


def _outliers(
    t: np.ndarray, y: np.ndarray, cps: list[ChangePoint], sigma: float
) -> tuple[np.ndarray, np.ndarray]:
    """Inlier mask by the local-residual rule (module docstring, step 3), one outlier at a time:
    the estimate that exceeds its limit by the largest factor leaves, and the others are judged
    again without it. A single pass let one far estimate tilt every neighbour's local fit — a
    jump on the latest of six recordings flagged all six, leaving no trend at all. Returns the
    inlier mask and each estimate's limit [rad]."""
    n = y.size
    inl = np.ones(n, dtype=bool)
    floor = max(OUTLIER_SIGMA * sigma, OUTLIER_FLOOR)
    for _ in range(n):
        r, step = _local_resid(t, y, cps, keep=inl)
        lim = np.maximum(floor, OUTLIER_STEPS * step)
        ratio = np.where(inl, np.abs(r) / lim, 0.0)
        worst = int(np.argmax(ratio))
        if ratio[worst] <= 1.0:
            break
        inl[worst] = False
    # an estimate left out early is judged again against the inliers alone, and rejoins when
    # within its limit: at a segment's end, a wild estimate next to the end point tilted the end
    # point's one-sided fit, and the end point left first (a 10 mrad outlier second-to-last of a
    # 40-estimate line took the latest, correct estimate with it, in 3 of 3 seeds)
    if inl.all():
        return inl, lim
    while not inl.all():  # each pass rejoins one or stops, judging with the current inliers
        r, step = _local_resid(t, y, cps, keep=inl, unjudged=np.inf)
        lim = np.maximum(floor, OUTLIER_STEPS * step)
        back = ~inl & (np.abs(r) <= lim)
        if not back.any():
            return inl, lim
        inl[int(np.flatnonzero(back)[np.argmin((np.abs(r) / lim)[back])])] = True
    # every one rejoined: the limits with all of them as neighbours
    return inl, np.maximum(floor, OUTLIER_STEPS * _local_resid(t, y, cps, keep=inl)[1])


def fit_trend(
    t: np.ndarray,
    y: np.ndarray,
    std: np.ndarray | None = None,
    threshold: float | None = None,
    t0: datetime | None = None,
    kind: str | None = None,
) -> AxisTrend:
    """Trend, change points and forecast of one axis's used estimates.

    Parameters
    ----------
    t : numpy.ndarray
        Days since ``t0``, increasing.
    y : numpy.ndarray
        δ̂ [rad].
    std : numpy.ndarray, optional
        Standard uncertainty of each δ̂ [rad] (the estimator's ``delta_std``); weights are
        1/σ_i² (relative; the residual scale is estimated). NaN = unknown: the median of the
        known ones; all unknown = equal weights. Its non-averaging part (:func:`systematic_std`)
        widens the band of the true δ and the forecast interval.
    threshold : float, optional
        Maintenance threshold [rad].
    t0 : datetime, optional
        Time of ``t = 0``.
    kind : str, optional
        The axis's kind: "prismatic" — δ̂, ``std`` and ``threshold`` in m, the series runs
        through the rules in units of :func:`trend_scale` and the trend is returned in m
        (module docstring, "Linear axes"); else rad.
    """
    scale = trend_scale(kind)
    if scale != 1.0:
        return _rescaled(
            fit_trend(
                t,
                np.asarray(y, dtype=float) / scale,
                None if std is None else np.asarray(std, dtype=float) / scale,
                None if threshold is None else threshold / scale,
                t0,
            ),
            scale,
        )
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    n = y.size
    s_in = np.full(n, np.nan) if std is None else np.asarray(std, dtype=float)
    known = np.isfinite(s_in) & (s_in > 0)
    if n and known.any():
        # an estimate without an uncertainty (older code version, another method) gets the
        # median of the known ones; weights are relative, the scale is estimated from the data
        s_all = np.where(known, s_in, float(np.median(s_in[known])))
        w_all = 1.0 / s_all**2
        w_all = w_all / np.mean(w_all)
    else:
        w_all = np.ones(n)
    cps, sigma = jumps_and_scale(t, y)
    inl = np.ones(n, dtype=bool)
    lim = np.full(n, np.inf)
    if n >= 5:
        inl, lim = _outliers(t, y, cps, sigma)
    iso = _isotonic(t, y, w_all, cps) if n else y.copy()
    trend = _fit_models(t, y, w_all, s_in, inl, cps, sigma, threshold, t0, iso, lim)
    # latest estimates the local test left out but the axis's own growth model (fitted without
    # them) predicts within the same limit: wear that accelerated past the local quadratic, not
    # outliers — they rejoin the fit (a jump or a bad recording stays out)
    last_in = int(np.flatnonzero(inl)[-1]) if inl.any() else n
    trail = np.arange(last_in + 1, n)
    back = np.zeros(0, dtype=int)
    if trend.model is not None and trail.size:
        dev = np.abs(y[trail] - trend.curve(t[trail])[0])
        back = trail[np.cumprod(dev <= lim[trail]).astype(bool)]
        if back.size:
            inl = inl.copy()
            inl[back] = True
            trend = _fit_models(t, y, w_all, s_in, inl, cps, sigma, threshold, t0, iso, lim)
    if not back.size and (trail.size >= 2 or (trend.model is None and trail.size)):
        # the growth model fitted without them cannot be fitted (too few left: a short history of
        # accelerating wear, 7 accurate estimates and the last 3 beyond the local quadratic) or does
        # not reach them (a linear fit without the last two of an accelerating axis): they rejoin
        # when the growth model fitted *with* them passes every used estimate within its limit.
        # A single latest estimate off the trend is not enough (a bad recording stays out).
        cand = inl.copy()
        cand[trail] = True
        with_them = _fit_models(t, y, w_all, s_in, cand, cps, sigma, threshold, t0, iso, lim)
        if with_them.model is not None and np.all(np.abs(y - with_them.curve(t)[0])[cand] <= lim[cand]):
            trend = with_them
    if n:
        # the display's monotone trend through the estimates the fit kept (B-07: it went through
        # a +12 mrad wild estimate and stayed 3.8 mrad above every inlier for five days)
        trend.isotonic = _isotonic(t, y, w_all, cps, trend.inlier)
    return trend


def _rescaled(tr: AxisTrend, scale: float) -> AxisTrend:
    """A trend fitted to δ / ``scale`` (:func:`fit_trend` of a linear axis) in the units of δ:
    every level, size, noise scale and parameter times ``scale`` (the growth constant k and the
    times stay); each AICc shifts by n·ln(scale²), as the fit to δ itself, so their difference —
    the model choice — is the same."""
    n_in = int(np.sum(tr.inlier)) if tr.t.size else 0
    curve = tr._curve
    return replace(
        tr,
        y=tr.y * scale,
        change_points=[replace(c, size=c.size * scale) for c in tr.change_points],
        sigma=tr.sigma * scale,
        params={k: (v if k == "k" else v * scale) for k, v in tr.params.items()},
        aicc={k: v + 2.0 * n_in * math.log(scale) for k, v in tr.aicc.items()},
        threshold=None if tr.threshold is None else tr.threshold * scale,
        isotonic=tr.isotonic * scale,
        sigma_sys=tr.sigma_sys * scale,
        _curve=None if curve is None else (lambda tt: tuple(c * scale for c in curve(tt))),
    )


def _fit_models(
    t: np.ndarray,
    y: np.ndarray,
    w_all: np.ndarray,
    s_in: np.ndarray,
    inl: np.ndarray,
    cps: list[ChangePoint],
    sigma: float,
    threshold: float | None,
    t0: datetime | None,
    iso: np.ndarray,
    lim: np.ndarray,
) -> AxisTrend:
    """Growth models on the inliers, model choice and forecast (module docstring, steps 4–5);
    ``lim`` [rad]: each estimate's outlier limit (:func:`judged_at`)."""
    s_sys = systematic_std(s_in[inl], sigma)
    trend = AxisTrend(t0, t, y, inl, cps, sigma, None, {}, {}, None, threshold, iso, s_sys)
    ti, yi, wi = t[inl], y[inl], w_all[inl]
    keep = [c for c in cps if np.any(ti >= c.t_days - 1e-9) and np.any(ti < c.t_days - 1e-9)]
    if yi.size < MIN_POINTS + len(keep):
        return trend
    lin = _fit_linear(ti, yi, wi, keep, s_sys)
    if lin is None:
        n_t = np.unique(ti).size
        trend.unfitted = (
            f"all {yi.size} usable estimates start at one time"
            if n_t == 1
            else f"the {yi.size} usable estimates start at only {n_t} distinct times, too few for "
            f"{count(len(keep), 'jump')}"
        )
        return trend
    # after a repair or re-adjustment (a negative change point) the new part wears at its own
    # rate: a slope-change term for the last segment, taken when its AICc is lower by more than
    # AICC_MARGIN (a shared slope forecast a repaired axis a month early, B-04)
    if keep and keep[-1].size < 0 and int(np.sum(ti >= keep[-1].t_days - 1e-9)) >= MIN_OWN_RATE_POINTS:
        own = _fit_linear(ti, yi, wi, keep, s_sys, t_own=keep[-1].t_days)
        if own is not None and own.aicc < lin.aicc - AICC_MARGIN:
            lin = own
    fits = {"linear": lin}
    acc = _fit_accelerating(ti, yi, wi, keep, lin, s_sys) if yi.size >= MIN_POINTS + 1 + len(keep) else None
    if acc is not None:
        fits["accelerating"] = acc
    trend.aicc = {k: f.aicc for k, f in fits.items()}
    chosen = lin
    if acc is not None and acc.aicc < lin.aicc - AICC_MARGIN and acc.params["k"] > 0:
        chosen = acc
    trend.model = chosen.name
    trend.params = chosen.params
    trend._curve = chosen.curve
    trend.t_now = judged_at(trend, lim)
    if threshold is not None:
        trend.forecast = _forecast(trend, trend.t_now, float(ti[-1] - ti[0]), threshold)
    return trend


def judged_at(trend: AxisTrend, lim: np.ndarray) -> float:
    """The time "now" of a fitted trend [days since ``t0``]: where the fitted δ now, the
    crossed verdict and the days left are evaluated.

    The latest inlier, or the latest of the later estimates the outlier test left out that
    either lies within :data:`JUDGE_REACH_STEPS` median recording intervals (of the inliers)
    of the latest inlier, or whose δ̂ is not below the fitted mean at its time by more than its
    outlier limit (the limit the outlier test judged it by). Within the usual spacing of the
    recordings the fitted curve is as good as at a recording, and one bad latest estimate does
    not move it (``test_crossing_is_judged_at_the_latest_recording_even_if_it_left_the_fit``);
    wear that ran ahead of the fit confirms the extrapolated level. An estimate far below the
    fitted mean after a gap contradicts the extrapolation (a machine that stood still for a
    month, a recording dated a month or years late): judging "now" at its date reported the
    straight line's value there — 429.9 mrad where the estimate said 131.9 — and a threshold
    crossing no estimate showed (s19 tester, F5).

    Parameters
    ----------
    trend : AxisTrend
        A trend with a fitted model and at least one inlier.
    lim : numpy.ndarray
        The outlier limit of each estimate [rad] (infinite where none was judged).

    Returns
    -------
    float
        Days since ``trend.t0``.
    """
    inl = np.flatnonzero(trend.inlier)
    last_in = int(inl[-1])
    t_now = float(trend.t[last_in])
    after = np.arange(last_in + 1, trend.t.size)
    if after.size:
        mean = trend.curve(trend.t[after])[0]
        ti = trend.t[trend.inlier]
        step = float(np.median(np.diff(ti))) if ti.size > 1 else 0.0
        near = trend.t[after] - t_now <= JUDGE_REACH_STEPS * step
        up = after[(trend.y[after] >= mean - lim[after]) | near]
        if up.size:
            t_now = float(trend.t[up[-1]])
    return t_now


def _forecast(trend: AxisTrend, t_last: float, span: float, thr: float) -> Forecast:
    now_mean = float(trend.curve(np.array([t_last]))[0][0])
    ahead = max(LOOKAHEAD_SPANS * max(span, 1.0), 365.0)
    tt = np.linspace(t_last, t_last + ahead, 40001)
    mean, lo, hi, _, _ = trend.curve(tt)
    if now_mean >= thr:
        # crossed: when did the fitted mean cross (looking back over the data)?
        back = np.linspace(trend.t[0], t_last, 4001)
        m_b, lo_b, hi_b, _, _ = trend.curve(back)
        tc = _first_crossing(back, m_b, thr)
        te = _first_crossing(back, hi_b, thr)
        tl = _first_crossing(back, lo_b, thr)
        return Forecast(tc, te, tl if tl is not None else t_last, True)
    tc = _first_crossing(tt, mean, thr)
    te = _first_crossing(tt, hi, thr)
    tl = _first_crossing(tt, lo, thr)
    return Forecast(tc, te, tl if tl is not None else math.inf, False)


def usable(r: dict[str, Any], kind: str | None = None) -> bool:
    """Whether a store row enters the trend: ok, excited, with δ̂ and a start time, and either
    converged or with a stated 95 % uncertainty 1.96·σ of at most :data:`UNCONVERGED_MAX_U95`
    (an excited estimate the estimator did not call converged — its uncertainty above its
    2 mrad claim — enters weighted by 1/σ²; docs/assumptions.md, "Wear tracking"), in units of
    :func:`trend_scale` of ``kind``, by default the row's ``axis_kind`` (``Store.estimates``;
    absent: rotary) — on a linear axis ±1.25 µm. An estimate a blocking warning made unconverged
    is stored without σ and so stays out (:func:`drivelash.wear.estimate.unconverged_cause`)."""
    if r["status"] != "ok" or not r["excitation_ok"] or r["delta"] is None or r["start_time"] is None:
        return False
    if r["converged"]:
        return True
    s = r["delta_std"]
    u95 = UNCONVERGED_MAX_U95 * trend_scale(kind or r.get("axis_kind"))
    return s is not None and math.isfinite(s) and 0 < 1.96 * s <= u95


def analyse(
    rows: list[dict[str, Any]], threshold: float | None, kind: str | None = None
) -> tuple[AxisTrend, list[dict[str, Any]]]:
    """Trend of one axis from its store rows (``Store.estimates(axis)``).

    ``kind``: the axis's kind (default: the rows' ``axis_kind``, else rotary); on a linear
    axis ("prismatic") δ̂ and ``threshold`` are in m (:func:`fit_trend`). Returns the trend of the
    used estimates and the used rows (:func:`usable`), in time order.
    """
    if kind is None:
        kind = next((r.get("axis_kind") for r in rows), None)
    used = [r for r in rows if usable(r, kind)]
    used.sort(key=lambda r: (r["start_time"], r["path"]))
    if not used:
        return fit_trend(np.array([]), np.array([]), None, threshold, None, kind), used
    t0 = used[0]["start_time"]
    t = np.array([(r["start_time"] - t0).total_seconds() / 86400.0 for r in used])
    y = np.array([r["delta"] for r in used], dtype=float)
    std = np.array([np.nan if r["delta_std"] is None else r["delta_std"] for r in used], dtype=float)
    return fit_trend(t, y, std, threshold, t0, kind), used
