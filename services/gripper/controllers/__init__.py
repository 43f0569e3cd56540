"""Release controllers of the object-transfer loop, all behind one vectorised interface.

Every controller implements `handover_model.grip.GripController`:

    controller.reset(n_episodes)              # fresh state for a batch of episodes
    grip_force_n = controller.step(sample)    # SensorSample in, commanded F_G (N) out

and works on numpy arrays of shape (n_episodes,), so the same object runs one live episode
(n = 1, the gripper service) or a Monte-Carlo batch. After each step, `controller.mode`
holds the controller's own estimate of the system mode (`Mode.GRASP/SLIP/RELEASE`) per
episode, from what it can sense (not ground truth).

Frames and units (thesis Fig. 15, DESIGN §5): gripper frame, x along the pull toward the
receiver, y DOWN; forces in N, accelerations in m/s² (a_y > 0: object falling), times in s.

Modules:
- `fail_safe`: the thesis's fail-safe law with integrator (eq 3.19) and its presets FS1/FS2/FS3
  (§3.6.1.1) and FS-sim-g1/g5 (the §3.5 simulation set with γ = 1 as printed in Table IV, or
  γ = 5 as stated in the text).
- `human_inspired`: Chan et al.'s law (eq 3.22, Fig. 25), F_G = m F_L + F_ZLG.
- `baselines`: the baselines of §3.1, `TimedRelease`, `ForceThresholdRelease` (Deyle et al.),
  `DisplacementRelease` (Bohren et al., release when an impedance-controlled hand is
  displaced by more than a distance).
- `slip_guard`: our slip-guarded load-share law (SG) and its versions.
- `common`: the force limit, defaults, checks, mode estimate and base class they share.
- `registry`: every controller by name (`make_controller`, `CONTROLLER_NAMES`).
"""
