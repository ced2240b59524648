"""A strong non-harmonic second peak in the PSD: fit it as a second damped mode beside the main one, and decide
whether the data separate the two (then the main mode's numbers stand) or not (then the verdict stays uncertain)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sloshid.core.spectrum import SpectralPeak, Spectrum
from sloshid.identification.estimates import estimate
from sloshid.identification.pt2fit import Z95, ZETA_BOUNDS, ModeFit, PT2Fit, WindowData, fit_two_modes

MIN_SEPARATION_BINS = 2.0
"""The fitted modes must lie at least this many Welch resolution bins apart (about four beats in the window):
closer modes trade amplitude and frequency with each other and least squares cannot tell them apart."""
MAX_SE_GROWTH = 2.0
"""If adding the second mode widens the main mode's frequency or damping interval by more than this factor, the two
are entangled in the fit and the main mode is not pinned down."""


@dataclass(frozen=True)
class SecondMode:
    """What became of a strong second PSD peak: the two-mode fit tried for it and whether it separated the modes."""

    signal: int
    """Index of the signal whose PSD showed the strongest such peak."""
    peak: SpectralPeak
    fit: PT2Fit
    """The two-mode fit (used as the result when `separated`)."""
    single: PT2Fit
    """The single-mode fit it is compared with (used as the result otherwise)."""
    problems: tuple[str, ...]
    """Why the modes could not be separated; empty when they were."""

    @property
    def separated(self) -> bool:
        """The two-mode fit passed every rule: its main mode replaces the single-mode estimate."""
        return not self.problems

    def amplitude_share(self, i: int) -> float:
        """Second mode's share A2 / (A1 + A2) of the oscillation amplitude at the start of window i."""
        a1, a2 = self.fit.amplitude(i, 0), self.fit.amplitude(i, 1)
        return a2 / (a1 + a2) if a1 + a2 > 0 else float("nan")

    def to_dict(self) -> dict:
        """f_hz and zeta of the second mode with errors, per-signal amplitude share, the verdict on separation."""
        m = _second(self.fit)
        se_w, se_z = np.sqrt(np.clip(np.diag(m.cov), 0, None))
        return {
            "psd_peak_f_hz": self.peak.f_hz,
            "psd_relative_power": self.peak.relative,
            "separated": self.separated,
            "problems": list(self.problems),
            "f_hz": estimate(m.omega_rad_s / (2 * math.pi), se_w / (2 * math.pi)).to_dict(),
            "zeta": estimate(m.zeta, se_z, ZETA_BOUNDS).to_dict(),
            "amplitude_share": [self.amplitude_share(i) for i in range(len(self.fit.linear))],
            "single_mode_f_hz": self.single.omega_rad_s / (2 * math.pi),
            "single_mode_zeta": self.single.zeta,
        }

    def summary(self) -> str:
        """One line for stdout."""
        m = _second(self.fit)
        se_f = math.sqrt(max(m.cov[0, 0], 0)) / (2 * math.pi)
        share = ", ".join(f"{100 * self.amplitude_share(i):.0f} %" for i in range(len(self.fit.linear)))
        head = (
            f"second mode: f2 = {m.omega_rad_s / (2 * math.pi):.4g} ± {se_f:.2g} Hz, zeta2 = {m.zeta:.3g}, "
            f"amplitude share {share}"
        )
        return head + (
            " (fitted beside the main mode)"
            if self.separated
            else " (not separated, main mode from the single-mode fit)"
        )


def _second(fit: PT2Fit) -> ModeFit:
    """The second mode of a two-mode fit (`fit_two_modes`)."""
    if fit.second is None:
        raise ValueError("the fit has no second mode: fit two modes first (fit_two_modes)")
    return fit.second


def strong_peaks(spectrum: Spectrum, ratio: float, fitted_hz: float | None = None) -> list[SpectralPeak]:
    """Non-harmonic secondary PSD peaks stronger than `ratio` of the main peak, strongest first; not those within a
    resolution bin of the `fitted_hz` mode or of its harmonics, which are that mode (a fit that left the searched band
    for a stronger mode beside it found that mode, not a second one)."""

    def of_fitted(f: float, fitted: float) -> bool:
        k = max(1, round(f / fitted))
        return abs(f - k * fitted) <= spectrum.resolution_hz

    return [
        p
        for p in spectrum.secondary
        if not p.harmonic and p.relative > ratio and (fitted_hz is None or not of_fitted(p.f_hz, fitted_hz))
    ]


def resolve_second_mode(
    windows: list[WindowData], single: PT2Fit, spectra: list[Spectrum], ratio: float, min_amplitude_snr: float
) -> SecondMode | None:
    """Fit two modes when some PSD shows a strong second peak (None when none does) and check separation."""
    f1 = single.omega_rad_s / (2 * math.pi)
    found = [(p.psd / s.peak_psd, i, p) for i, s in enumerate(spectra) for p in strong_peaks(s, ratio, f1)[:1]]
    if not found:
        return None
    _, i, peak = max(found, key=lambda c: c[0])
    two = fit_two_modes(windows, single, 2 * math.pi * peak.f_hz)
    problems = separation_problems(two, single, spectra[i].resolution_hz, min_amplitude_snr)
    return SecondMode(i, peak, two, single, tuple(problems))


def separation_problems(two: PT2Fit, single: PT2Fit, resolution_hz: float, min_amplitude_snr: float) -> list[str]:
    """The rule, in order: both modes off their search bounds, at least MIN_SEPARATION_BINS bins apart, the second
    mode's amplitude significant in some window, the two frequency intervals apart, and the main mode's intervals
    not widened more than MAX_SE_GROWTH-fold by the extra mode."""
    out = []
    m = _second(two)
    f1, f2 = two.omega_rad_s / (2 * math.pi), m.omega_rad_s / (2 * math.pi)
    if two.at_bound:
        out.append(f"{', '.join(two.at_bound)} ended on a search bound")
    bins = abs(f2 - f1) / resolution_hz
    if bins < MIN_SEPARATION_BINS:
        out.append(f"the modes are only {bins:.1f} resolution bins apart (at least {MIN_SEPARATION_BINS:g} needed)")
    snr = max(two.amplitude(i, 1) / two.amplitude_se(i, 1) for i in range(len(two.linear)))
    if not snr >= min_amplitude_snr:
        out.append(f"the second mode's amplitude is only {snr:.1f} standard errors above zero")
    se1, se2 = (math.sqrt(max(c[0, 0], 0)) / (2 * math.pi) for c in (two.cov, m.cov))
    if not Z95 * (se1 + se2) < abs(f2 - f1):
        out.append("the two frequencies' 95 % intervals overlap")
    for k, name in ((0, "frequency"), (1, "damping")):
        growth = math.sqrt(two.cov[k, k] / single.cov[k, k]) if single.cov[k, k] > 0 else float("inf")
        if not growth <= MAX_SE_GROWTH:
            out.append(f"the main mode's {name} interval widens {growth:.1f}-fold")
    return out
