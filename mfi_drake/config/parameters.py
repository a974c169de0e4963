"""The typed parameters of the MFI navigator and quadcopter chain, and of
the APF and GF baselines.

The paper gives no numbers for any of these; the defaults below were chosen
for a ~1 kg quadcopter cruising at 1 m/s among obstacles a few metres apart
(see docs/parameters.md for the reasoning). A scenario file
overrides any of them by name under `navigator:`.
"""

import dataclasses
import math
from dataclasses import dataclass, field


@dataclass
class NavigatorParams:
    # --- obstacle field, §IV-A ------------------------------------------
    c: float = 4.0
    """Boundary-following gain of eq 12 [N·s]."""
    r_l: float = 1.5
    """Boundary-following range of eq 13 [m], from the grown obstacle."""
    c_perp: float = 0.2
    """Collision-avoidance gain c⊥ of eq 15 [N·m³]."""
    r_b: float = 0.6
    """Collision-avoidance range of eq 15 [m]; must be < r_l."""
    tangent_blend: float = 0.3
    """|l_o| below which a deterministic tangent is blended into l_o [-]."""
    min_distance: float = 1e-3
    """Floor on r in eq 13/15 [m], so the fields stay finite at contact."""
    # --- repairs of the paper's field (docs/comparison.md, "MFI repairs");
    # `paper_form` turns them all off -------------------------------------
    follow_blocking_only: bool = True
    """(a) Eq 12 acts only on an obstacle the vehicle approaches (l_a·n > 0) or
    that lies toward the goal (n·l_g > 0, blended in over n·l_g ∈ [0, 0.1]);
    the paper's eq 12 also pulls a vehicle receding from an obstacle that is
    not in its way back toward it."""
    follow_ahead_only: bool = True
    """(h) With (a), an approached obstacle gets eq 12 in full only when it
    lies in or near the vehicle's path: the weight rises from 0 to 1 as the
    heading line's clearance from the closest point falls from 1 m to
    0.5 m (`fields.blocking_weight`). Eq 12's size is ∝ (l_a·n)·√(1 −
    (l_a·n)²), largest 45° off the heading, so obstacles the vehicle merely
    passed bent its path; eq 14 still acts on them within r_b. Beside a
    wall the clearance is small whatever the angle, so eq 12 stays whole."""
    continuous_side: bool = True
    """(b) Head-on, eq 11's current is lengthened along a tangent whose side
    turns over continuously in a thin band (`fields.artificial_current`),
    instead of flipping with the sign of l_o (a 1e-9 change of heading gave
    a ±1.7 N jump)."""
    project_others: bool = False
    """(c) Every obstacle but the nearest contributes only the part of its
    boundary following (eq 12) that does not push toward the nearest one (in
    the plane ⟂ v), so the sum keeps the nearest obstacle's boundary
    following (§IV-A); every obstacle's collision avoidance (eq 14) counts.
    Off by default: it raised collisions in the ablations (docs/comparison.md)."""
    hover_fade: bool = True
    """(d) F_a (eq 14) fades linearly below fade_speed: its direction follows
    that of v whatever |v|, so near hover it turns velocity noise into force."""
    fade_speed: float = 0.3
    """Speed below which `hover_fade` scales F_a by |v|/fade_speed [m/s]."""
    smooth_goal_turn: bool = True
    """(e) Eq 16–18's turning axis blends continuously into a fixed horizontal
    one as l_a and l_g become opposite, instead of switching from the
    bisector to a fixed r_ref (a 1.6–5.8 N jump of F_gc)."""
    tapered_range: bool = False
    """(f) Eq 13's f = v/r becomes f = v (1/r − 1/r_l), which vanishes at r_l
    as eq 15's f_a does at r_b, instead of ending with a jump of c·v/r_l
    (2.7 N at the defaults) each time an obstacle crosses r_l: the error
    controlled integrator had to shrink its steps at every crossing (~25 %
    fewer steps without the jump). Off by default: it also weakens eq 13
    inside r_l, so a wall met head-on is turned from late, at 0.3 m, where
    the vehicle then zigzags along it (docs/comparison.md)."""
    lag_drag: bool = True
    """(g) Eq 19's F_v also brakes by D = τ|F⊥|²/(m v) (to first order in
    τω; bounded by m v/(2τ)) while the vehicle turns under F⊥ = F_o + F_gc,
    with τ = 2ζ/ω_n the attitude loops' lag and m the vehicle's mass
    (`fields.lag_drag`): realised τ late, the ⟂ forces of eq 12–18 do the
    work τ|F⊥|²/m per second, and between obstacles they sped the vehicle up
    to 1.5–2 m/s, where the tilt limit could no longer turn it. F, F_a and
    F_gc stay ⟂ v; D vanishes on a straight cruise. Collisions at density
    0.2 fell from 5 to 1 of 200 held-out fields (docs/comparison.md)."""
    terminal_approach: bool = True
    """(i) Within r_gl of the goal (eq 21's PD zone) each obstacle's terms
    (eq 12, eq 14) fade to zero at r_gl/2, as Ge & Cui's goal-distance
    factor fades a potential field's repulsion, but only for an obstacle
    whose tangent plane at the closest point leaves the goal on the
    vehicle's side and within r_l of it: eq 20 then settles the vehicle at
    a goal near a surface instead of hovering where eq 14 balances it
    (`terminal.terminal_weight`, docs/goals.md)."""
    # --- goal attraction, §IV-B -----------------------------------------
    K_omega: float = 1.5
    """Heading gain K_ω of eq 17 [kg/s]."""
    K_v: float = 1.5
    """Speed gain K_v of eq 19 [N·s/m]."""
    v_d: float = 1.0
    """Desired cruise speed v_d of eq 19 [m/s]."""
    K_P: float = 1.5
    """Position gain K_P of eq 20 [N/m]."""
    K_D: float = 2.0
    """Velocity gain K_D of eq 20 [N·s/m]."""
    max_pd_force: float = 3.0
    """Saturation of |F_pd| (eq 20) [N], so a far goal is not a huge pull."""
    r_gl: float = 1.0
    """Goal distance below which eq 21 selects the PD term [m]."""
    goal_hysteresis: float = 0.25
    """Extra distance beyond r_gl needed to leave the PD mode [m]."""
    v_min: float = 0.2
    """Speed above which "v ≠ 0" of eq 21 holds (PD → cruise) [m/s]."""
    v_stop: float = 0.05
    """Speed below which cruise falls back to PD (eq 21, v = 0) [m/s]."""
    # --- quadcopter chain, §V -------------------------------------------
    K_Pv: float = 1.0
    """Planar force weight K_Pv of eq 22 [-]."""
    max_tilt: float = 0.5
    """Limit on the desired roll and pitch of eq 24 [rad]; F_n is scaled down to
    keep within it."""
    min_thrust_fraction: float = 0.1
    """Least thrust T, as a fraction of m·g: F_n is scaled down to keep T above
    it (eq 24) [-]."""
    brake_first: bool = True
    """When F_n asks for more than the vehicle delivers, deliver its part along
    −v (braking) first and scale the rest into what remains, instead of
    scaling all of F_n (`quadcopter.attitude_setpoint`). Scaling all of it
    let a large ⟂ command (eq 12–15 near an obstacle) scale eq 19's braking
    away, and the attitude lag then sped the vehicle up to 2–3 m/s into the
    obstacle: every collision of MFI on its training fields at density 0.2
    was one of these. For every method (it is the vehicle's chain)."""
    brake_margin: float = 0.0
    """With `brake_first`, deliver the braking only up to (1 − brake_margin)
    of the most the vehicle can deliver along −v, so the braking point stays
    inside the limits and the scale of the rest is a continuous function of
    F_n and v [-]. At 0 (the default) the braking sits on a limit when it
    saturates, and the rest's scale jumps between all and none where the
    rest runs along that limit (tree_on_ground: 3000 integrator steps of
    20–60 µs; 4692 steps against 1612 at 0.1). 0.1 lost one held-out field
    of 400 at density 0.2 that 0 flies safely (docs/comparison.md)."""
    tilt_compensation: bool = True
    """Divide T by cos(roll)·cos(pitch) so the vertical force is F_Qz."""
    yaw_follows_motion: bool = False
    """Yaw toward the horizontal velocity (so a forward camera looks where the
    vehicle goes, §VI-B's remark) instead of the paper's θ_y,d = 0."""
    attitude_natural_frequency: float = 15.0
    """ω_n of the roll/pitch/yaw loops of eq 25 [rad/s]: K_Pθ = J ω_n²."""
    attitude_damping_ratio: float = 0.9
    """ζ of eq 25's loops [-]: K_Dθ = 2 ζ ω_n J."""

    @property
    def terminal_zone(self) -> float:
        """Goal distance within which repair (i) fades obstacle terms [m]."""
        return self.r_gl

    @property
    def terminal_reach(self) -> float:
        """Goal clearance beyond which repair (i) leaves an obstacle whole [m]."""
        return self.r_l


REPAIRS = (
    "follow_blocking_only",
    "continuous_side",
    "project_others",
    "hover_fade",
    "smooth_goal_turn",
    "tapered_range",
    "lag_drag",
    "follow_ahead_only",
    "terminal_approach",
)


def paper_form(params: NavigatorParams) -> NavigatorParams:
    """`params` with every repair off: the paper's literal eq 11–21."""
    return dataclasses.replace(params, **dict.fromkeys(REPAIRS, False))


# Numeric fields for which 0 means "off" rather than nonsense.
MAY_BE_ZERO = {"brake_margin"}


def field_problems(params, prefix: str = "") -> list[tuple[str, object, str]]:
    """Every bool field a bool, every other field a finite number > 0 (≥ 0
    if in MAY_BE_ZERO; nested dataclasses checked field by field, named
    "outer.inner")."""
    problems = []
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        name = prefix + f.name
        if dataclasses.is_dataclass(value):
            problems += field_problems(value, name + ".")
        elif f.type is bool:
            if not isinstance(value, bool):
                problems.append((name, value, "must be true or false"))
        elif not isinstance(value, int | float) or not math.isfinite(value):
            problems.append((name, value, "must be a finite number"))
        elif name in MAY_BE_ZERO:
            if value < 0.0:
                problems.append((name, value, "must be ≥ 0"))
        elif value <= 0.0:
            problems.append((name, value, "must be > 0"))
    return problems


def validate_params(params: NavigatorParams) -> list[tuple[str, object, str]]:
    """Problems with `params` as (field, value, reason) triples; [] if none."""
    problems = field_problems(params)
    if not problems:
        if params.r_b >= params.r_l:
            problems.append(("r_b", params.r_b, f"must be < r_l = {params.r_l}"))
        if params.v_stop >= params.v_min:
            problems.append(
                ("v_stop", params.v_stop, f"must be < v_min = {params.v_min}")
            )
        if params.v_min >= params.v_d:
            problems.append(("v_min", params.v_min, f"must be < v_d = {params.v_d}"))
        if params.max_tilt >= math.pi / 2:
            problems.append(("max_tilt", params.max_tilt, "must be < π/2"))
        for name in ("tangent_blend", "brake_margin", "min_thrust_fraction"):
            if getattr(params, name) >= 1.0:
                problems.append((name, getattr(params, name), "must be < 1"))
    return problems


# --- the baselines (§VI-A; their fields are in `maths.baselines`) --------------
@dataclass
class AttractionParams:
    """Goal attraction of both baselines. The defaults equal MFI's eq 20 gains
    (K_P, K_D) and cruise speed v_d; tuning keeps v_max = v_d, so all three
    methods approach the goal at the same speed."""

    k_att: float = 1.5
    """Stiffness of the quadratic well around the goal [N/m]."""
    k_d: float = 2.0
    """Velocity damping [N·s/m]."""
    v_max: float = 1.0
    """Khatib's velocity limit [m/s]: beyond d* = k_d v_max / k_att the pull is
    the constant k_d v_max [N], so the vehicle cruises at v_max."""

    @property
    def cone_radius(self) -> float:
        """d* = k_d v_max / k_att [m]: within it the attraction is eq 20's PD."""
        return self.k_d * self.v_max / self.k_att


class BaselineTerminal:
    """The zone of a baseline's terminal approach (`terminal.terminal_weight`):
    d* = k_d v_max / k_att, within which its attraction is eq 20's PD."""

    @property
    def terminal_zone(self) -> float:
        return self.attraction.cone_radius


@dataclass
class ApfParams(BaselineTerminal):
    """The APF baseline (scenario field `apf:`). Defaults: the best of the
    grid in docs/tune_baselines.py (see docs/comparison.md)."""

    attraction: AttractionParams = field(default_factory=AttractionParams)
    eta: float = 0.02
    """Repulsion gain η [N·m³]."""
    rho_0: float = 1.5
    """Repulsion range ρ₀ [m], from the grown obstacle."""
    min_distance: float = 1e-3
    """Floor on r [m], so the repulsion stays finite at contact."""
    terminal_approach: bool = True
    """Ge & Cui's fix of goals near obstacles (IEEE T-RA 16(5), 2000): within
    d* = k_d v_max / k_att of the goal each obstacle's repulsion fades to
    zero at d*/2, for an obstacle whose tangent plane at the closest point
    leaves the goal on the vehicle's side and within ρ₀ of it
    (`terminal.terminal_weight`, docs/goals.md)."""

    @property
    def terminal_reach(self) -> float:
        return self.rho_0


@dataclass
class GfParams(BaselineTerminal):
    """The GF baseline (scenario field `gf:`). Defaults: the best of the grid
    in docs/tune_baselines.py (see docs/comparison.md); so strong that
    near an obstacle the steering is limited by the tilt limit, not k_g."""

    attraction: AttractionParams = field(default_factory=AttractionParams)
    k_g: float = 32.0
    """Gyroscopic gain [N·s]: |S ṗ| = k_g |ṗ| (1/r − 1/r_d) (l_a·n)."""
    r_d: float = 0.5
    """Radius of the detection shell [m], from the grown obstacle."""
    eta: float = 0.01
    """Repulsion gain η [N·m³] inside the safety shell."""
    rho_0: float = 0.3
    """Radius of the safety shell ρ₀ [m]; must be < r_d."""
    tangent_blend: float = 0.3
    """|n⊥| below which the fallback direction is blended in (head-on) [-]."""
    min_distance: float = 1e-3
    """Floor on r [m], so the fields stay finite at contact."""
    terminal_approach: bool = True
    """Within d* = k_d v_max / k_att of the goal (where the attraction is
    eq 20's PD) each obstacle's terms fade to zero at d*/2, as Ge & Cui's
    goal-distance factor fades the repulsion (IEEE T-RA 16(5), 2000), but
    only for an obstacle whose tangent plane at the closest point leaves
    the goal on the vehicle's side and within the obstacle's shell
    (`terminal.terminal_weight`, docs/goals.md). Off: the repulsion holds the
    vehicle short of a goal near a surface."""

    @property
    def terminal_reach(self) -> float:
        return self.r_d


def baseline_problems(params: ApfParams | GfParams) -> list[tuple[str, object, str]]:
    """Cross-field problems of a baseline's parameters as (field, value,
    reason); the per-field checks are `field_problems`."""
    if isinstance(params, GfParams):
        if params.rho_0 >= params.r_d:
            return [("rho_0", params.rho_0, f"must be < r_d = {params.r_d}")]
        if params.tangent_blend >= 1.0:
            return [("tangent_blend", params.tangent_blend, "must be < 1")]
    return []
