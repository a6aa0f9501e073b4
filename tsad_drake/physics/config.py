"""Every setting of the physics world, in one typed dataclass (SI units: m, s, rad, N, kg).

Gains are for the PD actuators the discrete SAP solver runs implicitly (`JointActuator.
set_controller_gains`): arm gains in N m / rad and N m s / rad per UR5e joint (shoulder pan
first), the finger gains in N / m and N s / m on the one finger actuator (the right finger follows
through the URDF's coupler constraint); that actuator's effort limit is the grip force, so a
finger commanded well inside the object presses with exactly `grip_force`.
"""

from __future__ import annotations

import dataclasses as dc

#: contact models a PhysicsConfig may name
CONTACT_MODELS = ("point", "hydroelastic")
#: how a grasped object is held in transport
GRASP_MODES = ("friction", "weld")


@dc.dataclass
class PhysicsConfig:
    """How the physics world simulates and judges one pick-and-place."""

    time_step: float = 1e-3  #: s, discrete MultibodyPlant step
    #: "point" (point contact everywhere) or "hydroelastic" (hydroelastic_with_fallback; objects
    #: and pads get compliant hydroelastic properties)
    contact_model: str = "point"
    discrete_approximation: str = "lagged"  #: SAP approximation of the discrete contact problem
    hydroelastic_modulus: float = 5e6  #: Pa, objects' and pads' modulus when hydroelastic
    #: point contact only: four small spheres on each pad's corners (proud of the pad face by
    #: `stud_proud`), so that a pad touches a flat face at four points, not one, and a held box
    #: cannot pivot about the line between the pads
    pad_studs: bool = True
    stud_radius: float = 0.002  #: m
    stud_proud: float = 0.0005  #: m
    #: N m / rad, proportional gains of the six UR5e joints
    arm_kp: list[float] = dc.field(
        default_factory=lambda: [6000.0, 6000.0, 4000.0, 800.0, 800.0, 500.0])
    #: N m s / rad, derivative gains of the six UR5e joints
    arm_kd: list[float] = dc.field(default_factory=lambda: [300.0, 300.0, 200.0, 30.0, 30.0, 15.0])
    #: feed-forward gravity torques computed on a robot-only plant at the desired configuration
    gravity_compensation: bool = True
    #: N, the finger actuator's effort limit: the squeeze of the closed fingers (2F-85: 20..235 N)
    grip_force: float = 40.0
    #: m, how far inside the planned closed opening each finger is commanded while holding (ramped
    #: in over the "close" segment); with `finger_kp` the actuator saturates at `grip_force` once
    #: the error exceeds grip_force / finger_kp (2 mm)
    squeeze: float = 0.02
    finger_kp: float = 20000.0  #: N / m, finger proportional gain
    finger_kd: float = 40.0  #: N s / m, finger derivative gain
    #: "friction": held by the fingers' friction alone; "weld": once both fingers touch the object
    #: at the end of the close, a weld constraint holds it where it is in the gripper until the
    #: fingers open (the fingers keep squeezing)
    grasp_mode: str = "friction"
    object_friction: float = 0.6  #: static = dynamic friction coefficient of every geometry
    settle_s: float = 0.5  #: s, simulated after the trajectory ends, before the outcome is read
    monitor_step: float = 0.02  #: s, how often tracking and the held object are sampled
    #: rad, largest arm joint tracking error tolerated before the action is called untracked
    tracking_tolerance: float = 0.05
    fall_tilt_deg: float = 20.0  #: deg, body z-axis to vertical beyond which an object has fallen
    floor_drop: float = 0.02  #: m, an object whose centre sinks this far has left the shelf floor
    disturb_m: float = 0.01  #: m, horizontal displacement that counts a non-picked object disturbed
    place_tolerance: float = 0.02  #: m, placement error within which the object "moved"
    lift_min: float = 0.01  #: m, how far the object must rise with the gripper to count as lifted

    def __post_init__(self) -> None:
        if self.contact_model not in CONTACT_MODELS:
            raise ValueError(f"contact_model must be one of {CONTACT_MODELS}")
        if self.grasp_mode not in GRASP_MODES:
            raise ValueError(f"grasp_mode must be one of {GRASP_MODES}")
        if len(self.arm_kp) != 6 or len(self.arm_kd) != 6:
            raise ValueError("arm_kp and arm_kd need one gain per UR5e joint (6)")
        if self.time_step <= 0 or self.squeeze <= 0 or self.grip_force <= 0:
            raise ValueError("time_step, squeeze and grip_force must be positive")

