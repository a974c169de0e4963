"""The analysis figures drawn from made-up series: every title inside the
figure, every legend entry drawn in view and named in words."""

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg

from mfi_drake.app.analysis_figures import plot_eigenvalues, plot_roa

GAINS = ("K_P", "K_D", "K_Ptheta", "K_Dtheta")


def crossings(*factors: float) -> list[dict]:
    return [
        {"factor": f, "value": 2.0 * f, "unstable": "below" if f < 1 else "above"}
        for f in factors
    ]


def titles_inside(fig) -> None:
    FigureCanvasAgg(fig).draw()
    box = fig.bbox
    for ax in fig.axes:
        if ax.get_title():
            title = ax.title.get_window_extent()
            assert box.x0 <= title.x0 and title.x1 <= box.x1, ax.get_title()
            assert box.y0 <= title.y0 and title.y1 <= box.y1, ax.get_title()


def test_every_root_locus_title_fits_even_with_two_crossings(tmp_path):
    factors = np.logspace(-2, 2, 41)
    # λ = −1 ± i·factor: some eigenvalue path per gain, and the crossings of
    # the real analysis's K_D (both ends lost, a long title).
    eig = np.stack([-1.0 + 1j * factors, -1.0 - 1j * factors], axis=1)
    sweep = {
        gain: {
            "factors": factors,
            "max_real_part": np.full(factors.size, -1.0),
            "stability_lost": crossings(0.0908, 10.4),
            "eigenvalues": eig,
            "default": 2.0,
            "units": "N·m·s/rad",
        }
        for gain in GAINS
    }
    fig = plot_eigenvalues(eig[20], sweep, str(tmp_path / "eigenvalues.png"))
    titles_inside(fig)


def test_roa_legends_name_only_what_is_drawn_in_view(tmp_path):
    angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    sos = {
        "lyapunov_S": np.diag([0.5, 0.5, 1.0, 1.0, 1.0, 1.0]),
        "rho_without_saturation": 0.05,
        "radius": 0.46,
    }
    # The reduced model converges on every ray up to 100: far off the view.
    reduced = (angles, np.full(angles.size, 100.0))
    directions = np.eye(6)[[0, 3, 1, 4]]
    radii = np.array([0.5, 2.0])
    sampled = {"outcomes": [[True] * 4, [True, True, False, True]], "radius": 0.5}
    fig = plot_roa(sos, reduced, sampled, radii, directions, str(tmp_path / "r.png"))
    titles_inside(fig)
    for ax in fig.axes:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        named = [line for line in ax.get_lines() if line.get_label()[0] != "_"]
        assert named and [t.get_text() for t in ax.get_legend().get_texts()] == [
            line.get_label() for line in named
        ]
        for line in named:
            x, y = line.get_xydata().T
            seen = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
            assert seen.any(), f"{line.get_label()!r} is not drawn in view"
            assert "_" not in line.get_label(), line.get_label()
