"""The README's example of a user's navigation field, for sweeps that
compare one (`--methods ...,user_field:field`, with benchmarks/ on
PYTHONPATH), and the same field with the shipped methods' terminal
approach (`user_field:field_near_goals`)."""

import numpy as np

from mfi_drake.maths.terminal import with_terminal_approach


def field(position, velocity, obstacle_points, goal):
    to_goal = goal - position
    force = 1.5 * to_goal / max(np.linalg.norm(to_goal), 1.0) - 2.0 * velocity
    for r in obstacle_points:  # push away from each obstacle, and round it to the left
        force -= (
            0.5 * (r + np.cross(r, [0.0, 0.0, 1.0])) / max(np.linalg.norm(r), 0.05) ** 3
        )
    return force


field_near_goals = with_terminal_approach(field, collision_radius=0.225)
