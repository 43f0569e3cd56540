"""Dyadic joint torque model (thesis §2.2, eqs 2.1–2.4).

Each actor's arm is a planar two-link manipulator (shoulder, elbow) in the task plane (x from
giver to receiver, z up, origin at the middle of the table top, metres). For a candidate
transfer point P the arm configuration of each actor follows from analytic inverse kinematics
on the physiologically natural branch (elbow below the shoulder–hand line). The cost is

    E_DJT(P) = Σ_j τ_giver,j(P)² + Σ_j τ_receiver,j(P)²                  (2.1, 2.2)

with τ the gravity torques of the links (N m) and the object's weight W_obj mapped onto the
giver's joints only, T_obj = J_giverᵀ W_obj (eq 2.3). For a point load at the grasp point,
Jᵀ W_obj equals the gravity torque of a point mass at the hand, which is how it is computed
here. The optimum (eq 2.4) is searched over the points both can reach, at or above the table
top: first a vectorised grid, then a scipy SLSQP refinement from the best grid point.

Each actor's local frame: u along the direction it faces (the giver faces +x, the receiver −x),
w up, origin at its shoulder. Joint angles: q1 is the upper arm's angle above the facing
horizontal, q2 the elbow flexion (0 = straight); q2 ≥ 0 puts the elbow below the line from
shoulder to hand, the natural branch for a hand held in front of the body.

Modules: `settings` (the model's choices), `arms` (kinematics and gravity torques of each
arm), `cost` (E_DJT at points and on a grid), `point_model` (the scalar cost for SLSQP),
`optimum` (eq 2.4: grid search and SLSQP refinement).
"""
