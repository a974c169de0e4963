"""The figures of `analysis`: eigenvalues and root loci, power of the
zero-work terms, heading decay (eq 17), region of attraction, drawn from
the series `studies.analysis.run_analysis` returns. Each writes its figure
and returns it."""

import textwrap

import numpy as np
from matplotlib.figure import Figure

from mfi_drake.app.figures import write_figure

SOS_BALL = "SOS-certified ball (reduced model)"
GAIN_LABELS = {"K_P": "K_P", "K_D": "K_D", "K_Ptheta": "K_Pθ", "K_Dtheta": "K_Dθ"}
TERM_COLOURS = {"F": "tab:blue", "F_a": "tab:orange", "F_gc": "tab:green"}


def _save(fig: Figure, path: str) -> Figure:
    fig.tight_layout()
    write_figure(fig, path)
    return fig


def plot_eigenvalues(eigenvalues: np.ndarray, sweep: dict, path: str) -> Figure:
    """Hover eigenvalues with damping lines, the root locus of each swept
    gain (colour = log10 of the factor on its default), and max Re λ."""
    fig = Figure(figsize=(15, 8.5))
    axes = fig.subplots(2, 3)
    ax = axes[0, 0]
    ax.scatter(eigenvalues.real, eigenvalues.imag, marker="x", color="black", s=50)
    reach = 1.1 * np.abs(eigenvalues).max()
    for zeta in (0.2, 0.5, 0.7, 0.9):
        angle = np.arccos(zeta)
        for sign in (1, -1):
            ax.plot(
                [0, -reach * np.cos(angle)],
                [0, sign * reach * np.sin(angle)],
                color="grey",
                lw=0.5,
                ls=":",
            )
        ax.annotate(f"ζ={zeta}", (-reach * zeta, reach * np.sin(angle)), fontsize=7)
    ax.axvline(0, color="red", lw=0.8)
    ax.set_title("closed loop at hover (PD mode): eigenvalues")
    ax.set_xlabel("Re λ [1/s]")
    ax.set_ylabel("Im λ [rad/s]")
    ax.grid(alpha=0.3)

    ax = axes[0, 1]
    for gain, s in sweep.items():
        (line,) = ax.semilogx(s["factors"], s["max_real_part"], label=GAIN_LABELS[gain])
        for c in s["stability_lost"]:
            ax.axvline(c["factor"], color=line.get_color(), ls="--", lw=0.8)
    ax.axvspan(0.1, 10.0, color="grey", alpha=0.12, label="a decade each side")
    ax.axhline(0, color="red", lw=0.8)
    ax.set_xlabel("gain / default")
    ax.set_ylabel("max Re λ [1/s]")
    ax.set_title("largest real part (dashed: stability lost)")
    ax.legend()
    ax.grid(alpha=0.3, which="both")

    left = 2.0 * eigenvalues.real.min()
    locus_axes = [axes[0, 2], axes[1, 0], axes[1, 1], axes[1, 2]]
    for ax, (gain, s) in zip(locus_axes, sweep.items(), strict=True):
        eig = s["eigenvalues"]
        colour = np.repeat(np.log10(s["factors"]), eig.shape[1])
        points = ax.scatter(
            eig.real.ravel(), eig.imag.ravel(), c=colour, cmap="viridis", s=6
        )
        ax.scatter(eigenvalues.real, eigenvalues.imag, marker="x", color="red", s=30)
        ax.axvline(0, color="red", lw=0.8)
        shown = eig.real >= left
        ax.set_xlim(left, max(2.0, 1.1 * eig.real.max()))
        top = 1.1 * max(np.abs(eig.imag[shown]).max(), 1.0)
        ax.set_ylim(-top, top)
        lost = ", ".join(
            f"{c['value']:.3g} (×{c['factor']:.3g}, unstable {c['unstable']})"
            for c in s["stability_lost"]
        )
        factors = s["factors"]
        # Wrapped: two crossings do not fit the subplot's width on one line.
        ax.set_title(
            f"{GAIN_LABELS[gain]} ×{factors[0]:.3g}…×{factors[-1]:.3g} of "
            f"{s['default']:.3g} {s['units']}\n"
            + textwrap.fill(f"stability lost at: {lost or 'nowhere in range'}", 48),
            fontsize=9,
        )
        ax.set_xlabel("Re λ [1/s]")
        ax.set_ylabel("Im λ [rad/s]")
        ax.grid(alpha=0.3)
        fig.colorbar(points, ax=ax, label="log10(gain / default)")
    return _save(fig, path)


def plot_power(series: dict, v_d: float, path: str) -> Figure:
    """Field-level and realised power of F, F_a, F_gc, and the speed."""
    t = series["t"]
    fig = Figure(figsize=(11, 10))
    axes = fig.subplots(3, 1, sharex=True)
    ax = axes[0]
    for name, p in series["field_power"].items():
        ax.semilogy(t, np.abs(p) + 1e-20, color=TERM_COLOURS[name], label=f"|{name}·v|")
    ax.set_ylim(1e-20, 1e-8)
    ax.axhline(1e-9, color="red", ls="--", lw=0.8, label="1e-9 W")
    ax.set_ylabel("field-level power [W]")
    ax.set_title("zero-work terms at field level (recomputed at the logged states)")
    ax.legend(fontsize=8, ncol=4)
    ax.grid(alpha=0.3)
    ax = axes[1]
    for name, p in series["realised_power"].items():
        ax.plot(t, p, color=TERM_COLOURS[name], label=f"{name} realised")
    ax.plot(t, series["lag_power"], color="black", lw=0.8, ls=":", label="(f − F_n)·v")
    ax.set_ylabel("realised power [W]")
    ax.set_title("as realised by the vehicle (each term through the attitude loop)")
    ax.legend(fontsize=8, ncol=4)
    ax.grid(alpha=0.3)
    ax = axes[2]
    ax.plot(t, series["speed"], color="black", label="|v|")
    ax.axhline(v_d, color="tab:green", ls="--", label="v_d")
    ax.fill_between(
        t,
        0,
        1,
        where=series["cruise"],
        color="tab:blue",
        alpha=0.1,
        transform=ax.get_xaxis_transform(),
        label="cruise mode",
    )
    ax.set_ylabel("speed [m/s]")
    ax.set_xlabel("time [s]")
    if series["cruise"].any():
        ax.set_xlim(0.0, min(t[-1], t[series["cruise"]].max() + 5.0))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def plot_heading(window: dict | None, far: dict, rate: float, path: str) -> Figure:
    """β(t): the scenario's obstacle-free cruise window and the far-goal run,
    each against the point-mass prediction of eq 17."""
    fig = Figure(figsize=(12, 4.5))
    axes = fig.subplots(1, 2)
    ax = axes[0]
    if window is not None:
        t = window["t"]
        ax.semilogy(t, window["measured"], color="black", label="vehicle")
        ax.semilogy(t, window["point_mass"], color="tab:blue", label="point mass")
        ax.semilogy(
            t,
            window["measured"][0] * np.exp(-rate * t),
            color="tab:red",
            ls="--",
            label="β0 exp(−K_ω t/m)",
        )
        ax.legend(fontsize=8)
    ax.set_title("scenario: cruise with no obstacle field")
    ax.set_xlabel("time in window [s]")
    ax.set_ylabel("heading error β [rad]")
    ax.grid(alpha=0.3, which="both")
    ax = axes[1]
    ax.semilogy(far["t"], far["vehicle"], color="black", label="vehicle")
    ax.semilogy(
        far["t"], far["closed_form"], color="tab:red", ls="--", label="β0 exp(−K_ω t/m)"
    )
    ax.set_title("goal 1 km ahead, start at v_d across (β0 = π/2)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("heading error β [rad]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return _save(fig, path)


def plot_roa(sos: dict, reduced, sampled: dict, radii, directions, path: str) -> Figure:
    """The (Δx, Δv_x) plane: the SOS-certified set and ball, the reduced
    model's sampled boundary, the vehicle's sampled starts; and every
    sampled start of the vehicle by radius."""
    fig = Figure(figsize=(13, 5.5))
    axes = fig.subplots(1, 2)
    ax = axes[0]
    S = np.asarray(sos["lyapunov_S"])[:2, :2]
    q = np.linspace(0, 2 * np.pi, 400)
    u = np.array([np.cos(q), np.sin(q)])
    scale = 1.0 / np.sqrt(np.einsum("ik,ij,jk->k", u, S, u))
    ax.plot(*(u * scale), color="tab:purple", label="SOS certified {V ≤ 1} (θ = ω = 0)")
    rho = sos["rho_without_saturation"]
    ax.plot(
        *(u * scale * np.sqrt(rho)),
        color="tab:purple",
        ls="--",
        label=f"{{V ≤ {rho:.3g}}}: no saturation on it",
    )
    ax.plot(*(u * sos["radius"]), color="tab:purple", ls=":", label=SOS_BALL)
    angles, boundary = reduced
    lim = 1.1 * max(scale.max(), 2.0)
    if boundary.min() < lim:  # else off the view: the title gives it
        ax.plot(
            boundary * np.cos(angles),
            boundary * np.sin(angles),
            color="tab:orange",
            label="reduced model, sampled boundary",
        )
    plane = np.abs(directions[:, [1, 2, 4, 5]]).sum(axis=1) == 0
    for outcomes, r in zip(sampled["outcomes"], radii, strict=False):
        for ok, d in zip(np.asarray(outcomes)[plane], directions[plane], strict=True):
            ax.scatter(
                r * d[0],
                r * d[3],
                marker="o" if ok else "x",
                color="tab:green" if ok else "tab:red",
                s=14,
            )
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ax.set_xlabel("Δx [m]")
    ax.set_ylabel("Δv_x [m/s]")
    ax.set_title(
        "PD mode, (Δx, Δv_x) plane; green o / red x: vehicle start converged / not"
        f"\n(reduced model converges on every ray up to ≥ {boundary.min():.3g})",
        fontsize=9,
    )
    ax.legend(fontsize=7, loc="lower left")
    ax.grid(alpha=0.3)
    ax = axes[1]
    for outcomes, r in zip(sampled["outcomes"], radii, strict=False):
        for j, ok in enumerate(outcomes):
            ax.scatter(
                j, r, marker="o" if ok else "x", color="tab:green" if ok else "tab:red"
            )
    ax.axhline(sos["radius"], color="tab:purple", ls=":", label=SOS_BALL)
    ax.axhline(
        boundary.min(),
        color="tab:orange",
        ls="--",
        label="reduced model, sampled boundary (nearest ray)",
    )
    ax.set_yscale("log")
    # Head room: the legend above the highest line, not on it.
    ax.set_ylim(top=5.0 * max(boundary.min(), np.max(radii), sos["radius"]))
    ax.set_xlabel("direction index (0–7: (Δx, Δv_x) plane)")
    ax.set_ylabel("offset radius |(Δp, Δv)|")
    ax.set_title(
        f"full vehicle samples: every start converged up to {sampled['radius']}"
    )
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return _save(fig, path)


def write_analysis_figures(series: dict, out_dir: str) -> dict[str, str]:
    """Writes the four figures of `series` (from `run_analysis`) under
    `out_dir`; returns {name: path}, the report's "figures"."""
    figures = {
        name: f"{out_dir}/{name}.png"
        for name in ("eigenvalues", "power", "heading", "roa")
    }
    plot_eigenvalues(
        series["eigenvalues"], series["gain_sweep"], figures["eigenvalues"]
    )
    plot_power(series["power"], series["v_d"], figures["power"])
    plot_heading(
        series["heading_window"],
        series["far_goal_heading"],
        series["heading_rate"],
        figures["heading"],
    )
    plot_roa(
        series["roa_sos"],
        series["roa_reduced_model"],
        series["roa_sampled"],
        series["roa_radii"],
        series["roa_directions"],
        figures["roa"],
    )
    return figures
