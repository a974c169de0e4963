"""The physical constants of the model, below every other module (the
configuration's vehicles and the maths both read them)."""

GRAVITY = 9.81  # m/s², as in Drake's QuadrotorPlant
