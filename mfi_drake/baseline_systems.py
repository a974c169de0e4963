"""The APF and GF baselines as systems with the ports of the MFI ones, so that
`diagram.build_diagram(..., method="apf" | "gf")` swaps only the field.

A method is two systems: a navigator ("state", "obstacle" → "obstacle_force"
F_o and "obstacle_force_terms", 6) and a goal attraction ("state",
"obstacle_force" → "navigation_force" F_n, "goal_force_terms", 9, "mode").
MFI's goal attraction is eq 16–21's `GoalAttractionSelector`; the baselines
have no cruise mode, so theirs is `PotentialGoalAttraction`, always "PD"
(eq 20 with Khatib's velocity limit, `baselines.attraction_field`).

What the 6 obstacle terms hold: MFI [F, F_a] (eq 12, eq 14); APF [F_rep, 0];
GF [S ṗ, F_rep]. The 9 goal terms: MFI [F_gc, F_v, F_pd]; baselines
[0, 0, F_att] with F_att = −∇U_att − k_d ṗ.
"""

import numpy as np
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from mfi_drake import baselines
from mfi_drake.fields import MODE_PD
from mfi_drake.systems import STATE_SIZE, ObstacleNavigator, _position_velocity


def ApfNavigator(params: baselines.ApfParams, goal, collision_radius: float):
    """APF's obstacle part: Khatib's repulsion; terms [F_rep, 0]."""
    return ObstacleNavigator(
        baselines.apf_obstacle_field, params, goal, collision_radius
    )


def GfNavigator(params: baselines.GfParams, goal, collision_radius: float):
    """GF's obstacle part: gyroscopic steering plus repulsion; terms
    [S ṗ, F_rep]."""
    return ObstacleNavigator(
        baselines.gf_obstacle_field, params, goal, collision_radius
    )


@TemplateSystem.define("PotentialGoalAttraction_")
def PotentialGoalAttraction_(T):
    class Impl(LeafSystem_[T]):
        """The baselines' goal attraction: F_n = F_o + F_att with
        F_att = −∇U_att − k_d ṗ (`baselines.attraction_field`).

        Inputs: "state" (12), "obstacle_force" F_o (3).
        Outputs: "navigation_force" F_n (3), "goal_force_terms" [0, 0, F_att]
        (9, laid out as the selector's [F_gc, F_v, F_pd]), "mode" (1, always
        fields.MODE_PD).
        """

        def _construct(self, attraction, goal, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.attraction = attraction
            self.goal = np.asarray(goal, dtype=float)
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            self._obstacle_force = self.DeclareVectorInputPort("obstacle_force", 3)
            state = {self._state.ticket()}
            self.DeclareVectorOutputPort(
                "navigation_force",
                3,
                lambda context, out: out.SetFromVector(
                    self._obstacle_force.Eval(context) + self._attraction(context)
                ),
                prerequisites_of_calc=state | {self._obstacle_force.ticket()},
            )
            self.DeclareVectorOutputPort(
                "goal_force_terms",
                9,
                lambda context, out: out.SetFromVector(
                    np.concatenate([np.zeros(6), self._attraction(context)])
                ),
                prerequisites_of_calc=state,
            )
            self.DeclareVectorOutputPort(
                "mode",
                1,
                lambda context, out: out.SetAtIndex(0, float(MODE_PD)),
                prerequisites_of_calc={self.nothing_ticket()},
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.attraction, other.goal, converter=converter)

        def _attraction(self, context):
            p, v = _position_velocity(self._state.Eval(context))
            return baselines.attraction_field(p, v, self.goal, self.attraction)

    return Impl


PotentialGoalAttraction = PotentialGoalAttraction_[None]
