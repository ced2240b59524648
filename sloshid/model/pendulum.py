"""The liquid model of design.md: a damped pendulum per horizontal axis (seed eq. 2, reconstructed eq. 3).

Signs follow `sloshid.model.conventions` (stated there once). The rate functions take `sin`/`cos` so that the
same expressions build CasADi graphs and NumPy values.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from sloshid.core.atomic import check_schema
from sloshid.core.errors import SMALL_FILE_BYTES, UserError, read_input
from sloshid.model.conventions import G

XI_CYLINDER = 1.8412
"""First root of J1', the first antisymmetric sloshing mode of an upright cylinder."""
XI_CYLINDER_SECOND = 3.0542
"""First root of J2', the cylinder's second azimuthal mode (the 3.9 Hz peak of the tilted measured runs)."""


@dataclass(frozen=True)
class SloshParams:
    """Pendulum parameters of one sloshing mode (seed Table I units)."""

    m_kg: float
    """Liquid mass; only scales d, the dynamics depend on d/m."""
    l_m: float
    """Pendulum length l = g / omega^2."""
    d_ns_per_m: float
    """Damping constant d = 2 m omega zeta."""

    def __post_init__(self) -> None:
        for name in ("m_kg", "l_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise UserError(f"{name} must be a positive number, got {value!r}.")
        if not (math.isfinite(self.d_ns_per_m) and self.d_ns_per_m >= 0):
            raise UserError(f"d_ns_per_m must be zero or positive, got {self.d_ns_per_m!r}.")

    @property
    def omega_rad_s(self) -> float:
        """Natural angular frequency sqrt(g/l)."""
        return math.sqrt(G / self.l_m)

    @property
    def f_hz(self) -> float:
        """Natural frequency in Hz."""
        return self.omega_rad_s / (2 * math.pi)

    @property
    def zeta(self) -> float:
        """Damping ratio d / (2 m omega)."""
        return self.d_ns_per_m / (2 * self.m_kg * self.omega_rad_s)

    @property
    def damping_rate_1_s(self) -> float:
        """d/m, the coefficient of the rate term in seed eq. 2."""
        return self.d_ns_per_m / self.m_kg

    @classmethod
    def from_modal(cls, omega_rad_s: float, zeta: float, m_kg: float = 1.0) -> SloshParams:
        """Build from natural frequency and damping ratio (seed eq. 6-7); m only scales d."""
        if not (omega_rad_s > 0):
            raise UserError(f"omega must be positive, got {omega_rad_s!r}.")
        return cls(m_kg=m_kg, l_m=G / omega_rad_s**2, d_ns_per_m=2 * m_kg * omega_rad_s * zeta)

    def scaled(self, omega_factor: float = 1.0, zeta_factor: float = 1.0) -> SloshParams:
        """The same liquid with its natural frequency and damping ratio multiplied (model-error studies)."""
        return SloshParams.from_modal(self.omega_rad_s * omega_factor, self.zeta * zeta_factor, self.m_kg)

    def to_dict(self) -> dict[str, float]:
        """Plain dict with unit-named keys, plus the derived modal values."""
        return {**asdict(self), "omega_rad_s": self.omega_rad_s, "f_hz": self.f_hz, "zeta": self.zeta}

    @classmethod
    def from_identify_json(cls, path: str | Path) -> SloshParams:
        """Read the parameters written by `sloshid identify` (values of `parameters.{omega_rad_s,zeta,m_kg}`)."""
        try:
            data = json.loads(read_input(path, "parameter file", SMALL_FILE_BYTES).decode("utf-8"))
        except (ValueError, UnicodeDecodeError) as exc:  # a JSONDecodeError, or a 5,000-digit number
            raise UserError(f"parameter file {path} is not valid JSON ({exc}).") from None
        except RecursionError:
            raise UserError(f"parameter file {path} nests arrays too deeply to be a parameter file.") from None
        check_schema(data, path)
        try:
            p = data["parameters"]
            omega = float(p["omega_rad_s"]["value"])
            zeta = float(p["zeta"]["value"])
            m = float(p.get("m_kg", {}).get("value", 1.0))
        except (KeyError, TypeError, ValueError, AttributeError):
            raise UserError(
                f"parameter file {path} lacks parameters.omega_rad_s.value and parameters.zeta.value; "
                "write it with `sloshid identify`."
            ) from None
        # named as the file names them: checked later, a negative zeta read as a negative d_ns_per_m
        if not (math.isfinite(omega) and omega > 0):
            raise UserError(f"parameter file {path}: parameters.omega_rad_s.value must be positive, got {omega!r}.")
        if omega > 2 * math.pi * MAX_MODE_HZ:
            raise UserError(
                f"parameter file {path}: parameters.omega_rad_s.value {omega:g} rad/s ({omega / (2 * math.pi):.4g} Hz) "
                f"is no sloshing mode (at most {MAX_MODE_HZ:g} Hz): is it in other units?"
            )
        if not (math.isfinite(zeta) and 0 <= zeta < 1):
            raise UserError(f"parameter file {path}: parameters.zeta.value must lie in [0, 1), got {zeta!r}.")
        if not (math.isfinite(m) and m > 0):
            raise UserError(f"parameter file {path}: parameters.m_kg.value must be positive, got {m!r}.")
        return cls.from_modal(omega, zeta, m)


MAX_MODE_HZ = 100.0
"""Highest first sloshing mode a parameter file may give: a vial of 5 mm has about 10 Hz; a trial's 1e6 rad/s sent
`plan` to ask for more solver iterations and `predict` whether its time was in milliseconds."""


@dataclass(frozen=True)
class IdentifiedFrequency:
    """What an identify JSON says of its natural frequency beyond the value: the 95 % interval and the verdict
    (None where a file written before per-parameter verdicts lacks them)."""

    ci95_hz: tuple[float, float] | None
    quality: str | None
    reasons: tuple[str, ...] = ()

    @classmethod
    def from_identify_json(cls, path: str | Path) -> IdentifiedFrequency:
        """Read parameters.f_hz.{ci95, quality, reasons} (the file is checked by SloshParams.from_identify_json); when
        jointly identified runs disagreed, the band is where one more run may land (fit.between_signals's prediction
        interval), which is what a move must hold over."""
        data = json.loads(read_input(path, "parameter file", SMALL_FILE_BYTES).decode("utf-8"))
        f = data.get("parameters", {}).get("f_hz", {})
        ci, where = f.get("ci95"), "parameters.f_hz.ci95"
        between = ((data.get("fit") or {}).get("between_signals") or {}).get("f_hz") or {}
        if between.get("disagree") and isinstance(between.get("prediction_interval95"), list):
            ci, where = between["prediction_interval95"], "fit.between_signals.f_hz.prediction_interval95"
        if "value" in f:  # the file's f_hz beside its omega: one edited without the other is refused, not half-used
            f_hz = SloshParams.from_identify_json(path).f_hz
            if not _number(f["value"]) or abs(f["value"] - f_hz) > 1e-6 * f_hz:
                raise UserError(
                    f"parameter file {path}: parameters.f_hz.value {f['value']!r} is not the frequency of "
                    f"parameters.omega_rad_s.value ({f_hz:.6g} Hz): was one of them edited?"
                )
        interval = None
        if ci is not None:
            if not (isinstance(ci, list) and len(ci) == 2 and all(_number(c) and c > 0 for c in ci) and ci[0] <= ci[1]):
                raise UserError(f"parameter file {path}: {where} must be two positive numbers, low first, got {ci!r}.")
            interval = (float(ci[0]), float(ci[1]))
        return cls(interval, f.get("quality"), tuple(f.get("reasons") or ()))


def _number(value: object) -> bool:
    """A finite JSON number (not a string, not a boolean)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


TABLE_I = SloshParams(m_kg=0.5, l_m=0.021, d_ns_per_m=1.51)
"""The seed paper's identified liquid (Table I): f = 3.44 Hz, zeta = 0.070."""


class PendulumParams(Protocol):
    """What the equations of motion read of a liquid: a `SloshParams`, or CasADi symbols standing for its numbers
    (the planners' problems)."""

    @property
    def l_m(self) -> Any: ...

    @property
    def damping_rate_1_s(self) -> Any: ...


def angle_accel(
    angle: Any,
    rate: Any,
    u: Any,
    params: PendulumParams,
    g_eff: Any = G,
    sin: Callable = np.sin,
    cos: Callable = np.cos,
) -> Any:
    """Seed eq. 2: angular acceleration of a surface angle that tilts toward +u under acceleration u."""
    c = cos(angle)
    return (u / params.l_m) * c - (g_eff / params.l_m) * sin(angle) - params.damping_rate_1_s * rate * c * c


def spherical_accel(
    phi: float,
    theta: float,
    dphi: float,
    dtheta: float,
    ux: float,
    uy: float,
    g_eff: float,
    params: SloshParams,
    drag: float = 0.0,
    sin: Callable = math.sin,
    cos: Callable = math.cos,
    sqrt: Callable = math.sqrt,
) -> tuple[Any, Any]:
    """(phi'', theta'') of one spherical pendulum in the surface angles (normal = Ry(theta) Rx(phi) z): the two
    horizontal directions coupled (a swirl's precession, Muchacho et al. 2022), damped on the bob's velocity. With
    phi = 0 it is seed eq. 2 for theta; with theta = 0, for -phi (`angle_accel`, up to the damping's cos^2). `drag`
    (per rad) adds damping in proportion to the bob's angular speed: a steep wave's breaking, which bounds what
    vertical pumping (parametric resonance) can build up. `sin`, `cos`, `sqrt`: CasADi's for the compiled integrator."""
    sp, cp, st, ct = sin(phi), cos(phi), sin(theta), cos(theta)
    w2 = 1.0 / params.l_m
    c = params.damping_rate_1_s + drag * sqrt(dphi * dphi + cp * cp * dtheta * dtheta)
    phi_dd = -sp * cp * dtheta * dtheta - w2 * (ux * st * sp + uy * cp + g_eff * ct * sp) - c * dphi
    theta_dd = w2 * (ux * ct - g_eff * st) / cp + 2.0 * sp / cp * dphi * dtheta - c * dtheta
    return phi_dd, theta_dd


def pendulum_rhs_3d(
    o: Any, u: Any, params: PendulumParams, sin: Callable = np.sin, cos: Callable = np.cos
) -> list[Any]:
    """Reconstructed seed eq. 3: o = [x,y,z,phi,theta,psi, x',y',z',phi',theta',psi'], u = [ux,uy,uz].

    Returns the 12 time derivatives as a list (stack with np.array or casadi.vertcat).
    """
    g_eff = G + u[2]
    tilt_y_dd = angle_accel(-o[3], -o[9], u[1], params, g_eff, sin, cos)  # -phi tilts toward +uy
    theta_dd = angle_accel(o[4], o[10], u[0], params, g_eff, sin, cos)
    return [o[6], o[7], o[8], o[9], o[10], 0 * o[11], u[0], u[1], u[2], -tilt_y_dd, theta_dd, 0 * o[11]]


def linear_tf_coeffs(params: SloshParams) -> tuple[list[float], list[float]]:
    """Seed eq. 5, angle per acceleration: num/den of (1/g) / ((l/g) s^2 + (d l/(g m)) s + 1)."""
    l, g = params.l_m, G
    return [1.0 / g], [l / g, params.damping_rate_1_s * l / g, 1.0]


def linear_tf(params: SloshParams):
    """Seed eq. 5 as a python-control transfer function (rad per m/s^2)."""
    import control

    num, den = linear_tf_coeffs(params)
    return control.tf(num, den)


def rotation_depths(radius_m: float, fill_height_m: float, modes: int = 200) -> tuple[float, float]:
    """How far below the surface's centre an upright cylinder's liquid feels a turn of the container, in linear potential
    theory: (the first mode's pendulum pivot, the point whose acceleration the faster modes follow). Mode n answers to
    the acceleration of the point (2 R / xi_n) tanh(xi_n h / 2 R) below the surface (its Stokes-Joukowski potential),
    so the first mode is a world-frame pendulum of length l_1 pivoted l_1 higher; the others, quasi-static, to their
    points weighted by their wall shares 2 / (xi_n^2 - 1). A translation feels the same at every height."""
    from scipy.special import jnp_zeros

    if radius_m <= 0 or fill_height_m <= 0:
        raise UserError("container radius and fill height must both be positive.")
    xi = jnp_zeros(1, modes)
    depth = 2 * radius_m / xi * np.tanh(xi * fill_height_m / (2 * radius_m))
    share = 2 / (xi**2 - 1)
    length = radius_m / (xi[0] * math.tanh(xi[0] * fill_height_m / radius_m))
    return float(depth[0] - length), float(np.sum(share[1:] * depth[1:]) / np.sum(share[1:]))


def cylinder_first_mode_omega(radius_m: float, fill_height_m: float, xi: float = XI_CYLINDER) -> float:
    """Analytic sloshing mode of an upright cylinder: omega^2 = (g xi / R) tanh(xi h / R); the first mode by default,
    another with its Bessel root xi (XI_CYLINDER_SECOND: the second azimuthal mode)."""
    if radius_m <= 0 or fill_height_m <= 0:
        raise UserError("container radius and fill height must both be positive.")
    return math.sqrt(G * xi / radius_m * math.tanh(xi * fill_height_m / radius_m))
