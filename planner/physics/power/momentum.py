r"""Rotor power from actuator-disk momentum theory: hover, climb, descent, forward flight.

Layer 1: pure, vectorised functions in SI units. Every function takes floats, ndarrays or
pandas Series (broadcasting) and returns the same kind; NaN samples propagate; physically
impossible parameters raise :class:`planner.errors.ModelError` naming the parameter.

Sign conventions: the climb rate :math:`V_c` is positive up; the disk tilt
:math:`\alpha` is positive forward (nose down, thrust tilted forward); the inflow through
the disk (induced velocity and the axial component of the free stream) is positive
downwards, i.e. in the normal working state of a lifting rotor.

Throughout, :math:`x = V_z / v_h` is the axial free-stream component through the disk
(:math:`V_z = V\sin\alpha + V_c\cos\alpha`), :math:`\mu_h = V_{xy}/v_h` the in-plane
component (:math:`V_{xy} = |V\cos\alpha - V_c\sin\alpha|`), both scaled by the hover
induced velocity, and :math:`\lambda = v_i / v_h`.

References
----------
.. [1] J. G. Leishman, Principles of Helicopter Aerodynamics, 2nd ed. Cambridge, U.K.:
   Cambridge Univ. Press, 2006: ch. 2 (momentum theory in hover, §2.14 axial climb and
   descent, vortex-ring and windmill-brake states and the empirical induced-velocity
   curve), ch. 5 (forward flight: Glauert's induced-velocity relation, profile power
   :math:`(1 + K\mu^2)` with :math:`K \approx 4.65`).
.. [2] H. Glauert, "A general theory of the autogyro," Aeronautical Research Committee,
   London, U.K., R&M 1111, 1926.
.. [3] Z. Liu, R. Sengupta and A. Kurzhanskiy, "A power consumption model for multi-rotor
   small unmanned aircraft systems," in Proc. ICUAS 2017, pp. 310–315: vertical descent
   power from momentum theory's normal working state,
   :math:`\kappa T(-V_d/2 + \sqrt{V_d^2/4 + T/(2\rho A)})`.

The battery power is :math:`P_{batt} = P_R/\eta` as in [UAV23] eq. 22–24.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import ModelError
from planner.physics.atmosphere import G
from planner.physics.kernel import kernel
from planner.physics.limits import DESCENT_INFLOW_WEIGHT_MAX, DESCENT_INFLOW_WEIGHT_MIN
from planner.physics.numeric import like_inputs, require

# Leishman's empirical fit of measured induced velocity in the vortex-ring and turbulent
# wake states, -2 <= V_c/v_h <= 0 ([1], §2.14).
VRS_KAPPA = 1.15
VRS_COEFFICIENTS = (-1.125, -1.372, -1.718, -0.655)  # k1..k4

MU_BLEND = 1.0
"""In-plane speed, in hover induced velocities, above which the vortex-ring correction
has vanished and Glauert's relation is used as it is [unitless]."""

X_REGULARISE = 1.5
"""Descent ratio :math:`-V_z/v_h` beyond which the in-plane speed used in Glauert's
relation is raised to at least :data:`MU_BLEND` (see :func:`induced_velocity`)
[unitless]."""

WINDMILL_BLEND = 0.5
"""Width in :math:`x = V_c/v_h` over which the windmill-brake branch is eased in below
:math:`x = -2` [unitless]."""

PROFILE_K = 4.65
"""Profile-power growth with advance ratio, :math:`P_0 = P_{0,h}(1 + K\\mu^2)`, [1] ch. 5
[unitless]."""

DEFAULT_FIGURE_OF_MERIT = 0.6
"""Hover figure of merit used when neither ``figure_of_merit`` nor
``profile_power_ratio`` is given: typical of small fixed-pitch propellers (0.5–0.65)
[unitless]."""

DEFAULT_ROTOR_CT = 0.01
"""Rotor thrust coefficient :math:`C_T = T/(\\rho A (\\Omega R)^2)` used to estimate the
tip speed when ``tip_speed`` is None. The 7-inch propeller of [UAV23] (section 4)
(:math:`C_T` = 0.0823 in the propeller convention) has 0.0106 [unitless]."""

MIN_ROTOR_SPEED_RATIO = 0.5
"""Default idle rotor speed as a fraction of the hover rotor speed (power floor), as in
:data:`planner.physics.power.multirotor.MIN_ROTOR_SPEED_RATIO` [unitless]."""

_NEWTON_ITERATIONS = 60


# --------------------------------------------------------------------------------------
# Dimensionless kernels (ndarray in, ndarray out)
# --------------------------------------------------------------------------------------
def _smoothstep(t):
    """C¹ ramp from 0 (t <= 0) to 1 (t >= 1)."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _vrs_fit(x):
    """Leishman's fit, scaled to join hover (x=0) and windmill brake (x=-2) at λ = 1."""
    k1, k2, k3, k4 = VRS_COEFFICIENTS

    def poly(z):
        return VRS_KAPPA + k1 * z + k2 * z**2 + k3 * z**3 + k4 * z**4

    end_excess = poly(-2.0) / VRS_KAPPA - 1.0  # 0.0226: the fit's mismatch at x = -2
    return poly(x) / VRS_KAPPA + 0.5 * x * end_excess


def _axial_ratio(x, descent_weight=0.0):
    """λ = v_i/v_h in purely axial flight, continuous over all three working states;
    ``descent_weight`` moves the vortex-ring branch towards momentum theory's normal
    working state continued (:func:`induced_velocity`, "Slow descent")."""
    x = np.asarray(x, dtype=float)
    with np.errstate(invalid="ignore"):
        climb = -0.5 * x + np.sqrt(0.25 * x**2 + 1.0)
        windmill = -0.5 * x - np.sqrt(np.maximum(0.25 * x**2 - 1.0, 0.0))
    xv = np.clip(x, -2.0, 0.0)
    vrs = _vrs_fit(xv)
    if np.any(descent_weight):
        normal = -0.5 * xv + np.sqrt(0.25 * xv**2 + 1.0)
        vrs = vrs + descent_weight * (normal - vrs) * (1.0 + 0.5 * xv)
    # momentum theory's windmill branch leaves x = -2 with an infinite slope, which
    # measurements do not show: ease into it over -2 - WINDMILL_BLEND <= x <= -2
    s = _smoothstep((-2.0 - x) / WINDMILL_BLEND)
    windmill = s * windmill + (1.0 - s) * 1.0
    out = np.where(x >= 0.0, climb, np.where(x >= -2.0, vrs, windmill))
    return np.where(np.isnan(x), np.nan, out)


def _glauert_ratio(mu, x):
    """Root λ > 0 of λ² (μ² + (x + λ)²) = 1 (Glauert), bracketed Newton iteration.

    The root is unique when μ >= 0.62 or x > -1.755 (the fold of the relation lies in
    μ < 0.6204, x <= -1.755); callers only use it there. At most
    ``_NEWTON_ITERATIONS`` steps, fewer once every root has settled to rounding.
    """
    mu2 = np.asarray(mu, dtype=float) ** 2
    x = np.asarray(x, dtype=float)
    mu2, x = np.broadcast_arrays(mu2, x)
    out = np.empty(x.shape)
    _glauert_kernel(np.ascontiguousarray(mu2).ravel(), np.ascontiguousarray(x).ravel(),
                    _NEWTON_ITERATIONS, out.reshape(-1))
    return out


@kernel
def _glauert_kernel(mu2, x, iterations, out):  # pragma: no cover - compiled
    """The bracketed Newton iteration of :func:`_glauert_ratio`, element by element: each
    root stops as soon as it has settled to rounding (a compiled loop: the vectorised
    form iterated every element until the slowest had settled)."""
    for k in range(x.size):
        m2, xk = mu2[k], x[k]
        if np.isnan(m2) or np.isnan(xk):
            out[k] = np.nan
            continue
        lo = 0.0
        hi = 1.0 + max(-xk, 0.0)  # f(hi) >= 0 for any μ
        lam = 0.5 * hi
        for _ in range(iterations):
            s = xk + lam
            q = m2 + s * s
            f = lam * lam * q - 1.0
            if f > 0.0:
                hi = lam
            else:
                lo = lam
            den = 2.0 * lam * q + 2.0 * lam * lam * s
            step = lam - f / den if den != 0.0 else np.nan
            new = step if (step > lo and step < hi) else 0.5 * (lo + hi)
            done = abs(new - lam) <= 1e-15 * abs(new)
            lam = new
            if done:
                break
        out[k] = lam


def _induced_ratio(mu, x, descent_weight=0.0):
    """λ = v_i/v_h for any combination of in-plane (μ ≥ 0) and axial (x) inflow.

    λ = λ_G(μ', x) + w(μ) [λ_A(x) − λ_G(μ'_0, x)]; see :func:`induced_velocity`.
    """
    mu = np.asarray(mu, dtype=float)
    x = np.asarray(x, dtype=float)
    d = _smoothstep(-x / X_REGULARISE)
    mu_reg = np.sqrt(mu**2 + d * np.maximum(MU_BLEND**2 - mu**2, 0.0))
    lam_glauert = _glauert_ratio(mu_reg, x)
    lam_glauert_axial = _glauert_ratio(np.sqrt(d) * MU_BLEND, x)
    w = 1.0 - _smoothstep(mu / MU_BLEND)
    return lam_glauert + w * (_axial_ratio(x, descent_weight) - lam_glauert_axial)


# --------------------------------------------------------------------------------------
# Public functions
# --------------------------------------------------------------------------------------
def hover_induced_velocity(thrust, air_density, disk_area):
    r"""
    Induced velocity of an actuator disk in hover.

    Parameters
    ----------
    thrust : numeric
        Thrust carried by the disk(s), ≥ 0. [N]
    air_density : numeric
        Air density. [kg m⁻³]
    disk_area : numeric
        Disk area; for :math:`N` equal rotors pass the total thrust and the total area
        (same result). [m²]

    Returns
    -------
    velocity : numeric
        :math:`v_h`. [m s⁻¹]

    Notes
    -----
    .. math:: v_h = \sqrt{\frac{T}{2 \rho A}}

    [1]_, ch. 2 (hover momentum theory).
    """
    t, rho, a = _disk_inputs(thrust, air_density, disk_area)
    return like_inputs(_hover_velocity(t, rho, a), thrust, air_density, disk_area)


def _disk_inputs(thrust, air_density, disk_area):
    """Thrust [N], air density [kg m⁻³] and disk area [m²], checked."""
    return (require(thrust, "thrust", ge=0.0, unit="N"),
            require(air_density, "air_density", gt=0.0, unit="kg/m³"),
            require(disk_area, "disk_area", gt=0.0, unit="m²"))


def _hover_velocity(thrust, air_density, disk_area):
    """:math:`v_h = \\sqrt{T/(2\\rho A)}` ([1]_ ch. 2), ndarrays. [m s⁻¹]"""
    return np.sqrt(thrust / (2.0 * air_density * disk_area))


def ideal_hover_power(thrust, air_density, disk_area):
    r"""
    Ideal (induced) power of an actuator disk in hover.

    Parameters
    ----------
    thrust, air_density, disk_area : numeric
        As in :func:`hover_induced_velocity`. [N], [kg m⁻³], [m²]

    Returns
    -------
    power : numeric
        :math:`P_{ideal} = T v_h`. [W]

    Notes
    -----
    .. math:: P_{ideal} = \frac{T^{3/2}}{\sqrt{2 \rho A}}

    [1]_, ch. 2. At constant thrust it scales as :math:`\rho^{-1/2}`.
    """
    t, rho, a = _disk_inputs(thrust, air_density, disk_area)
    return like_inputs(t * _hover_velocity(t, rho, a), thrust, air_density, disk_area)


def induced_velocity(thrust, air_density, disk_area, airspeed=0.0, climb_rate=0.0,
                     disk_tilt=0.0, descent_inflow_weight=0.0):
    r"""
    Induced velocity of an actuator disk in climb, descent and forward flight.

    Parameters
    ----------
    thrust, air_density, disk_area : numeric
        As in :func:`hover_induced_velocity`. [N], [kg m⁻³], [m²]
    airspeed : numeric, default 0
        Horizontal true airspeed :math:`V`, ≥ 0. [m s⁻¹]
    climb_rate : numeric, default 0
        Vertical speed :math:`V_c`, up positive (negative = descent). [m s⁻¹]
    disk_tilt : numeric, default 0
        Forward tilt of the disk :math:`\alpha` (thrust tilted forward). [rad]
    descent_inflow_weight : float, default 0
        :math:`w` in [−1, 2] (:mod:`planner.physics.limits`), the weight of momentum
        theory's inflow against Leishman's curve in slow axial descent (Notes, "Slow
        descent"); 0 is Leishman's curve. [unitless]

    Returns
    -------
    velocity : numeric
        Induced velocity :math:`v_i` through the disk, positive down, always > 0 for
        positive thrust (0 for zero thrust). [m s⁻¹]

    Notes
    -----
    The free stream relative to the disk has an axial component
    :math:`V_z = V\sin\alpha + V_c\cos\alpha` (through the disk, positive down, a climb
    along the disk axis) and an in-plane component
    :math:`V_{xy} = |V\cos\alpha - V_c\sin\alpha|` (for :math:`V_c = 0` the usual
    :math:`V\sin\alpha`, :math:`V\cos\alpha`). With :math:`x = V_z/v_h`,
    :math:`\mu_h = V_{xy}/v_h`, :math:`\lambda = v_i/v_h`:

    *Glauert's relation* [2]_, [1]_ ch. 5, valid in the normal working state and in
    forward flight,

    .. math:: \lambda = \frac{1}{\sqrt{\mu_h^2 + (x + \lambda)^2}},

    is solved by a bracketed Newton iteration (fixed count, vectorised). In pure axial
    climb (:math:`\mu_h = 0`, :math:`x \ge 0`) it reduces to the closed form
    :math:`\lambda = -x/2 + \sqrt{x^2/4 + 1}`.

    *Axial descent* (:math:`\mu_h = 0`, :math:`x < 0`), [1]_ §2.14, three regions:

    - :math:`x \ge 0`: normal working state, the closed form above;
    - :math:`-2 \le x < 0`: vortex-ring and turbulent-wake states, where momentum theory
      fails. Leishman's empirical curve
      :math:`\kappa + k_1 x + k_2 x^2 + k_3 x^3 + k_4 x^4` (:math:`\kappa` = 1.15,
      :math:`k_1..k_4` = −1.125, −1.372, −1.718, −0.655) fits *measured* induced
      velocity, which already contains the induced-power factor (1.15 at hover). It is
      therefore divided by 1.15 (so that it joins hover at :math:`\lambda = 1`; the
      caller's ``induced_factor`` is applied in the power), and a linear term
      :math:`0.0113\,x` is added so that it also joins the windmill branch at
      :math:`x = -2` (the fit gives 1.023 there): the curve is continuous, the
      adjustment at most 2.3 %;
    - :math:`x < -2`: windmill-brake state,
      :math:`\lambda_W = -x/2 - \sqrt{x^2/4 - 1}`. Momentum theory leaves
      :math:`x = -2` with an infinite slope, which measurements ([1]_ §2.14) do not
      show, so the branch is eased in over :math:`-2.5 \le x \le -2`:
      :math:`\lambda = s\lambda_W + (1 - s)`, :math:`s = \mathrm{smoothstep}((-2 - x)/0.5)`
      (pure windmill brake from :math:`x = -2.5`, i.e. :math:`\lambda \le 0.5`).

    *Slow descent* (:math:`-2 \le x < 0`). Leishman's curve is a fit through widely
    scattered measurements on helicopter rotors ([1]_ §2.14); at small :math:`|x|` it
    keeps the induced power :math:`T(v_i + V_c)` at its hover value, whereas momentum
    theory's normal working state, continued into descent
    (:math:`\lambda_N = -x/2 + \sqrt{x^2/4 + 1}`, as small-UAS power models take it
    [3]_), lets it fall by :math:`W|V_c|/2`. Which holds for a given rotor is a
    measurement, so the weight :math:`w` of momentum theory is a parameter of the
    aircraft:

    .. math:: \lambda = \lambda_L(x) + w\,[\lambda_N(x) - \lambda_L(x)]\,(1 + x/2),

    :math:`\lambda_L` Leishman's curve above. The factor :math:`1 + x/2` brings every
    :math:`w` back to Leishman's curve at :math:`x = -2`, where it joins the windmill
    brake: the curve stays continuous. Near hover the ideal power :math:`T(v_i + V_c)`
    falls as :math:`T v_h[1 - (0.033 + 0.467\,w)|x|]`: :math:`w` = 0 keeps it
    (Leishman), :math:`w` = 1 gives back momentum theory's half of :math:`W|V_c|`,
    :math:`w` = 2 (the largest, the induced velocity staying near its hover value)
    nearly the whole of it; below 0 (at least −1) the power rises as the descent
    begins. A
    fixed-pitch rotor also slows in descent (more blade incidence from the up-flow), so its
    profile power falls as well; at these descent rates the weight takes that up too.

    *Mixed forward flight and descent.* Glauert's relation has a unique root for
    :math:`\mu_h \ge 0.62` or :math:`x > -1.755`; below that (the fold, which is where
    the vortex ring lives) it has three. The solution used everywhere is

    .. math::

        \lambda = \lambda_G(\mu', x) + w(\mu_h)\,[\lambda_A(x) - \lambda_G(\mu'_0, x)],

    where :math:`\lambda_A` is the axial model above, :math:`\lambda_G` the Glauert root,
    :math:`w = 1 - \mathrm{smoothstep}(\mu_h/\mu_b)` fades the axial (vortex-ring)
    correction out by :math:`\mu_b = 1` (forward speed of one hover induced velocity,
    which is where the vortex-ring state disappears in practice), and the in-plane speed
    in the Glauert term is regularised in descent,
    :math:`\mu'^2 = \mu_h^2 + d(x)\max(\mu_b^2 - \mu_h^2, 0)`,
    :math:`\mu'_0 = \sqrt{d(x)}\,\mu_b`, with :math:`d` a smoothstep from 0 at
    :math:`x = 0` to 1 at :math:`x = -1.5`, so that the root is unique. Hence: exactly
    the axial model at :math:`\mu_h = 0`; exactly Glauert for any climb or level flight
    (:math:`x \ge 0`) and for :math:`\mu_h \ge 1`; a smooth interpolation between them
    otherwise. The result is continuous, finite and positive everywhere.
    """
    t, rho, a = _disk_inputs(thrust, air_density, disk_area)
    v = require(airspeed, "airspeed", ge=0.0, unit="m/s")
    vc = np.asarray(climb_rate, dtype=float)
    alpha = np.asarray(disk_tilt, dtype=float)
    vh = _hover_velocity(t, rho, a)
    axial = v * np.sin(alpha) + vc * np.cos(alpha)
    inplane = np.abs(v * np.cos(alpha) - vc * np.sin(alpha))
    vi = induced_from_components(vh, axial, inplane, _descent_weight(descent_inflow_weight))
    return like_inputs(vi, thrust, air_density, disk_area, airspeed, climb_rate, disk_tilt)


def _descent_weight(weight) -> float:
    """The slow-descent inflow weight, checked (:func:`induced_velocity`). [unitless]"""
    return float(require(weight, "descent_inflow_weight", ge=DESCENT_INFLOW_WEIGHT_MIN,
                         le=DESCENT_INFLOW_WEIGHT_MAX))


def induced_from_components(hover_velocity, axial, inplane, descent_inflow_weight=0.0):
    r"""Induced velocity from :math:`v_h` and the free-stream components through the disk.

    :math:`v_i = \lambda(\mu_h, x)\, v_h` with :math:`x = V_z/v_h`,
    :math:`\mu_h = V_{xy}/v_h` (module notes, :func:`induced_velocity`); 0 where
    :math:`v_h = 0` (no thrust), NaN where it is NaN.

    Parameters
    ----------
    hover_velocity : ndarray
        Hover induced velocity :math:`v_h` at the thrust. [m s⁻¹]
    axial, inplane : ndarray
        Axial (through the disk, positive down) and in-plane free-stream components
        :math:`V_z`, :math:`V_{xy}`. [m s⁻¹]
    descent_inflow_weight : float, default 0
        As in :func:`induced_velocity`. [unitless]

    Returns
    -------
    velocity : ndarray
        :math:`v_i`. [m s⁻¹]
    """
    vh = hover_velocity
    safe = np.where(vh > 0.0, vh, 1.0)
    lam = _induced_ratio(inplane / safe, axial / safe, descent_inflow_weight)
    return np.where(vh > 0.0, lam * vh, np.where(np.isnan(vh), np.nan, 0.0))


@dataclass(frozen=True)
class RotorPowerTerms:
    """The aerodynamic power budget of a multirotor, term by term (all rotors together).

    Each field has the kind of the inputs (float, ndarray or Series).
    """

    induced: Any
    """Induced power :math:`\\kappa T v_i`. [W]"""
    profile: Any
    """Blade profile power :math:`P_0 = r_0 T v_h (1 + 4.65\\mu^2)`. [W]"""
    parasite: Any
    """Body parasite power :math:`D V = \\tfrac12\\rho V^3 f`. [W]"""
    climb: Any
    """Rate of change of potential energy :math:`W V_c` (negative in descent). [W]"""
    shaft: Any
    """Sum of the four terms, the rotors' shaft power (may be < 0 in a fast descent). [W]"""
    battery: Any
    """Battery (discharge) power. [W]"""
    thrust: Any
    """Total thrust :math:`T`. [N]"""


@dataclass(frozen=True)
class MomentumPower(RotorPowerTerms):
    """Power budget of a multirotor from momentum theory (:func:`momentum_power_components`).

    The terms of :class:`RotorPowerTerms`, with the battery power
    :math:`\\max(P_{shaft}, P_{floor})/\\eta + P_S`, and:
    """

    floor: Any
    """Shaft power at idle rotor speed, the least the motors draw. [W]"""
    induced_velocity: Any
    """Induced velocity :math:`v_i`. [m s⁻¹]"""


def profile_power_ratio_of(figure_of_merit, profile_power_ratio, induced_factor):
    r"""Hover profile power over ideal hover power, :math:`r_0 = P_{0,h}/(T v_h)`.

    Given directly (``profile_power_ratio``, ≥ 0) or from the hover figure of merit,
    :math:`r_0 = 1/FM - \kappa` (from :math:`FM = T v_h/(\kappa T v_h + P_{0,h})`,
    [1]_ ch. 2); neither: FM = :data:`DEFAULT_FIGURE_OF_MERIT`. [unitless]

    Raises
    ------
    ModelError
        Both given, or an FM above :math:`1/\kappa` (a negative profile power).
    """
    if figure_of_merit is not None and profile_power_ratio is not None:
        raise ModelError("give figure_of_merit or profile_power_ratio, not both")
    if profile_power_ratio is not None:
        return require(profile_power_ratio, "profile_power_ratio", ge=0.0)
    fm = DEFAULT_FIGURE_OF_MERIT if figure_of_merit is None else figure_of_merit
    fm = require(fm, "figure_of_merit", gt=0.0, le=1.0)
    r0 = 1.0 / fm - induced_factor
    if np.any(r0 < 0.0):
        raise ModelError(
            f"figure_of_merit must be <= 1/induced_factor (profile power >= 0), "
            f"got figure_of_merit={figure_of_merit}, induced_factor={induced_factor}")
    return r0


def rotor_shaft_terms(mass, air_density, rotors, diameter, airspeed, climb_rate, drag_area,
                      induced_factor, figure_of_merit, profile_power_ratio, tip_speed,
                      load_factor, min_rotor_speed_ratio, gravity, thrust=None,
                      descent_inflow_weight=0.0) -> dict:
    r"""
    The rotors' aerodynamic power, term by term, from momentum theory (ndarrays).

    The part :func:`momentum_power_components` and
    :func:`planner.physics.power.rotor_losses.rotor_losses_components` share: the inputs
    checked, the trim (or the given ``thrust``), the inflow and the four power terms and
    the idle-speed floor of :func:`momentum_power_components` (its Notes give the
    equations, [1]_ ch. 2 and 5). Parameters as there, in SI units.

    Returns
    -------
    terms : dict of ndarray
        ``weight`` [N], ``thrust`` [N], ``induced_velocity`` [m s⁻¹], ``induced``,
        ``profile``, ``parasite``, ``climb``, ``shaft``, ``floor`` [W], and
        ``profile_power_ratio`` :math:`r_0` [unitless].
    """
    m = require(mass, "mass", gt=0.0, unit="kg")
    rho = require(air_density, "air_density", gt=0.0, unit="kg/m³")
    n_rot = require(rotors, "rotors", ge=1.0)
    if np.any(n_rot != np.round(n_rot)):
        raise ModelError(f"rotors must be a whole number >= 1, got {rotors}")
    d = require(diameter, "diameter", gt=0.0, unit="m")
    v = require(airspeed, "airspeed", ge=0.0, unit="m/s")
    vc = np.asarray(climb_rate, dtype=float)
    f = require(drag_area, "drag_area", ge=0.0, unit="m²")
    kappa = require(induced_factor, "induced_factor", ge=1.0)
    n = require(load_factor, "load_factor", ge=1.0)
    r = require(min_rotor_speed_ratio, "min_rotor_speed_ratio", ge=0.0, le=1.0)
    r0 = profile_power_ratio_of(figure_of_merit, profile_power_ratio, kappa)
    if tip_speed is not None:
        vtip = require(tip_speed, "tip_speed", gt=0.0, unit="m/s")

    weight = m * gravity
    area = n_rot * 0.25 * np.pi * d**2
    drag = 0.5 * rho * v**2 * f
    t = (np.sqrt((n * weight) ** 2 + drag**2) if thrust is None
         else require(thrust, "thrust", ge=0.0, unit="N"))
    vh = _hover_velocity(t, rho, area)
    with np.errstate(invalid="ignore", divide="ignore"):
        axial = np.where(t > 0.0, (drag * v + weight * vc) / np.where(t > 0.0, t, 1.0), 0.0)
        inplane = np.sqrt(np.maximum(v**2 + vc**2 - axial**2, 0.0))
    vi = induced_from_components(vh, axial, inplane, _descent_weight(descent_inflow_weight))
    if tip_speed is None:
        vtip = vh * np.sqrt(2.0 / DEFAULT_ROTOR_CT)
    with np.errstate(invalid="ignore", divide="ignore"):
        mu = np.where(vtip > 0.0, inplane / np.where(vtip > 0.0, vtip, 1.0), 0.0)

    induced = kappa * t * vi
    profile = r0 * t * vh * (1.0 + PROFILE_K * mu**2)
    parasite = drag * v
    climb = weight * vc
    vh_weight = _hover_velocity(weight, rho, area)
    return {"weight": weight, "thrust": t, "induced_velocity": vi, "induced": induced,
            "profile": profile, "parasite": parasite, "climb": climb,
            "shaft": induced + profile + parasite + climb,
            "floor": r**3 * weight * vh_weight * (kappa + r0), "profile_power_ratio": r0}


def tilted_disk_velocities(airspeed, climb_rate, air_density, mass, tilt_drag_area,
                           load_factor=1.0, gravity=G):
    r"""
    The rotor disks' in-plane and axial speed in steady flight, with the disks tilted
    against a body drag area.

    Parameters
    ----------
    airspeed : numeric
        Horizontal airspeed :math:`V`. [m/s]
    climb_rate : numeric
        Vertical speed :math:`V_c`, up positive. [m/s]
    air_density : numeric
        [kg m⁻³]
    mass : numeric
        All-up mass. [kg]
    tilt_drag_area : numeric
        Drag area :math:`f_t` the disks' forward tilt balances. [m²]
    load_factor : numeric, default 1
        Lift over weight (turns). [unitless]
    gravity : float
        [m s⁻²]

    Returns
    -------
    inplane, axial : ndarray
        :math:`V_{xy}` and :math:`V_z`. [m/s]

    Notes
    -----
    In steady flight the thrust's forward component balances the body drag
    :math:`D_t = \tfrac12\rho V^2 f_t` and its vertical component the weight,
    :math:`T = \sqrt{(nW)^2 + D_t^2}`; the free stream's component along the tilted
    thrust axis is then :math:`V_z = (D_t V + W V_c)/T` and the in-plane one
    :math:`V_{xy} = \sqrt{V^2 + V_c^2 - V_z^2}` (Leishman 2006 ch. 5, the energy
    method: :math:`T V_z` is the power to overcome the drag and to climb) [1]_.
    These are the velocities a record's ``axial_speed_ms`` gives
    (:meth:`planner.chain.flightstate.FlightState.rotor_velocities`): a power model fed
    them flies the predicted tilt as it flies a measured one. With :math:`f_t = 0` and
    :math:`n = 1` they are :math:`(V, V_c)`.
    """
    v = require(airspeed, "airspeed", ge=0.0, unit="m/s")
    vc = np.asarray(climb_rate, dtype=float)
    rho = require(air_density, "air_density", gt=0.0, unit="kg/m³")
    m = require(mass, "mass", gt=0.0, unit="kg")
    f = require(tilt_drag_area, "tilt_drag_area", ge=0.0, unit="m²")
    n = require(load_factor, "load_factor", ge=1.0)
    weight = m * gravity
    drag = 0.5 * rho * v**2 * f
    thrust = np.sqrt((n * weight) ** 2 + drag**2)
    axial = (drag * v + weight * vc) / thrust
    inplane = np.sqrt(np.maximum(v**2 + vc**2 - axial**2, 0.0))
    return inplane, axial


def terms_like_inputs(terms: dict, battery, inputs) -> dict:
    """Each term broadcast against the battery power and given the kind of the inputs
    (:func:`planner.physics.numeric.like_inputs`); units unchanged."""
    return {name: like_inputs(np.broadcast_to(value, np.broadcast(battery, value).shape),
                              *inputs) for name, value in terms.items()}


def momentum_power_components(mass, air_density, rotors, diameter, efficiency, airspeed=0.0,
                              climb_rate=0.0, drag_area=0.0, induced_factor=1.15,
                              figure_of_merit=None, profile_power_ratio=None, tip_speed=None,
                              system_power=0.0, load_factor=1.0,
                              min_rotor_speed_ratio=MIN_ROTOR_SPEED_RATIO, gravity=G,
                              descent_inflow_weight=0.0):
    r"""
    Multirotor power budget from momentum theory, term by term.

    Parameters
    ----------
    mass : numeric
        All-up mass. [kg]
    air_density : numeric
        Air density. [kg m⁻³]
    rotors : int
        Number of rotors :math:`N` (equal, sharing the thrust, no interference). [unitless]
    diameter : numeric
        Rotor diameter. [m]
    efficiency : numeric
        Battery-to-shaft efficiency :math:`\eta` (ESC × motor), in (0, 1]. [unitless]
    airspeed : numeric, default 0
        Horizontal true airspeed :math:`V`, ≥ 0. [m s⁻¹]
    climb_rate : numeric, default 0
        Vertical speed :math:`V_c`, up positive. [m s⁻¹]
    drag_area : numeric, default 0
        Body equivalent flat-plate area :math:`f`, ≥ 0. [m²]
    induced_factor : numeric, default 1.15
        Induced-power factor :math:`\kappa \ge 1` (non-uniform inflow, tip losses; 1.15
        is Leishman's typical value). [unitless]
    figure_of_merit : numeric, optional
        Hover figure of merit :math:`FM = P_{ideal}/P_{hover}`, in
        (0, 1/:math:`\kappa`]. Default 0.6 when ``profile_power_ratio`` is not given
        either. [unitless]
    profile_power_ratio : numeric, optional
        Hover profile power over ideal hover power, :math:`P_{0,h}/(T v_h)`, ≥ 0.
        Give this or ``figure_of_merit``, not both. [unitless]
    tip_speed : numeric, optional
        Blade tip speed :math:`\Omega R`; None estimates it at each thrust as
        :math:`v_h\sqrt{2/C_T}` with :math:`C_T` = 0.01. [m s⁻¹]
    system_power : numeric, default 0
        Constant electrical load :math:`P_S`, ≥ 0. [W]
    load_factor : numeric, default 1
        Ratio of the thrust's weight-balancing part to the weight, ≥ 1 (a level turn:
        :math:`n = 1/\cos\phi`). [unitless]
    min_rotor_speed_ratio : float, default 0.5
        Idle rotor speed over hover rotor speed, in [0, 1], sets the power floor.
        [unitless]
    gravity : float, default 9.80665
        Acceleration of gravity. [m s⁻²]
    descent_inflow_weight : float, default 0
        Weight of momentum theory's inflow against Leishman's vortex-ring curve in slow
        axial descent, in [−1, 2] (:func:`induced_velocity`, "Slow descent"). [unitless]

    Returns
    -------
    components : MomentumPower
        Induced, profile, parasite and climb power, shaft power, floor, battery power
        [W], thrust [N] and induced velocity [m s⁻¹].

    Raises
    ------
    ModelError
        If a parameter is physically impossible (e.g. mass ≤ 0, efficiency outside
        (0, 1], diameter ≤ 0, FM > 1/κ) or both FM and profile ratio are given.

    Notes
    -----
    *Trim.* Body drag :math:`D = \tfrac12\rho V^2 f` (from the horizontal airspeed, the
    vertical drag is neglected). The thrust balances the weight (times the load factor
    in a turn) and the drag: :math:`T = \sqrt{(nW)^2 + D^2}`.

    *Shaft power* ([1]_ ch. 2 and 5, energy method):

    .. math::

        P = \kappa T v_i + P_0 + D V + W V_c, \qquad
        P_0 = P_{0,h}\,(1 + 4.65\,\mu^2), \quad \mu = \frac{V_{xy}}{\Omega R}

    :math:`D V + W V_c = \vec T\cdot\vec u` is the thrust times the axial free stream
    through the tilted disk, :math:`V_z = (DV + WV_c)/T`; the in-plane component is
    :math:`V_{xy} = \sqrt{V^2 + V_c^2 - V_z^2}`; :math:`v_i` comes from
    :func:`induced_velocity` with these components (Glauert in forward flight,
    Leishman's empirical curve in the vortex-ring state, moved towards momentum theory
    by ``descent_inflow_weight``, windmill brake beyond).

    *Profile power.* :math:`P_{0,h} = r_0\,T v_h` with
    :math:`r_0 = 1/FM - \kappa` (from
    :math:`FM = T v_h / (\kappa T v_h + P_{0,h})`) or the given
    ``profile_power_ratio``. It is evaluated at the actual thrust: for a fixed-pitch
    propeller :math:`\Omega^2 \propto T` so :math:`P_0 \propto \Omega^3 \propto T^{3/2}`,
    like :math:`T v_h`. Default FM 0.6 (:math:`r_0` = 0.517 with :math:`\kappa` = 1.15).
    The growth :math:`1 + K\mu^2`, :math:`K` = 4.65, is Leishman's for helicopter
    rotors ([1]_ ch. 5), taken over for small propellers.

    *Floor (no regeneration).* In a fast descent the induced term plus :math:`W V_c`
    goes negative (windmill brake). The rotors still spin at no less than an idle speed
    :math:`r\,\Omega_{hover}` and ESCs do not regenerate, so the shaft power is at least
    :math:`r^3` times the hover shaft power at the weight,
    :math:`P_{floor} = r^3\, W v_h(W)\,(\kappa + r_0)`, :math:`r` = 0.5 by default
    (12.5 %), the same floor as :func:`planner.physics.power.multirotor.propeller_battery_power`.

    *Battery* ([UAV23] eq. 22–24):

    .. math:: P_{batt} = \frac{\max(P, P_{floor})}{\eta} + P_S
    """
    terms = rotor_shaft_terms(mass, air_density, rotors, diameter, airspeed, climb_rate,
                              drag_area, induced_factor, figure_of_merit, profile_power_ratio,
                              tip_speed, load_factor, min_rotor_speed_ratio, gravity,
                              descent_inflow_weight=descent_inflow_weight)
    eta = require(efficiency, "efficiency", gt=0.0, le=1.0)
    ps = require(system_power, "system_power", ge=0.0, unit="W")
    battery = np.maximum(terms["shaft"], terms["floor"]) / eta + ps
    inputs = (mass, air_density, rotors, diameter, efficiency, airspeed, climb_rate,
              drag_area, induced_factor, system_power, load_factor)
    out = terms_like_inputs({k: terms[k] for k in (
        "induced", "profile", "parasite", "climb", "shaft", "floor", "thrust",
        "induced_velocity")} | {"battery": battery}, battery, inputs)
    return MomentumPower(**out)


def momentum_battery_power(mass, air_density, rotors, diameter, efficiency, **kwargs):
    r"""
    Battery power of a multirotor from momentum theory.

    Parameters
    ----------
    mass, air_density, rotors, diameter, efficiency, **kwargs
        As in :func:`momentum_power_components`. [kg], [kg m⁻³], [unitless], [m],
        [unitless]

    Returns
    -------
    power : numeric
        Battery (discharge) power, ≥ :math:`P_S` + floor/η, finite for any descent or
        forward speed. [W]

    Notes
    -----
    .. math:: P_{batt} = \frac{\max(\kappa T v_i + P_0 + D V + W V_c,\ P_{floor})}{\eta}
              + P_S

    See :func:`momentum_power_components` for the terms, the defaults (κ 1.15, FM 0.6,
    tip speed from :math:`C_T` 0.01, idle speed 0.5 of hover) and the references.
    """
    return momentum_power_components(mass, air_density, rotors, diameter, efficiency,
                                     **kwargs).battery
