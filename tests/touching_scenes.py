"""Hand-built scenes whose objects touch (issue 38: contact is not overlap). Imported by tests."""

from tsad_drake.scenario import ObjectConfig, Scenario


def box(name: str, x: float, y: float, sx: float = 0.05, sy: float = 0.05, height: float = 0.14,
        yaw: float = 0.0) -> ObjectConfig:
    kind = "square_pillar" if sx == sy else "rectangular"
    return ObjectConfig(name=name, kind=kind, shape="box", size=[sx, sy, height], x=x, y=y,
                        yaw=yaw)


def cylinder(name: str, x: float, y: float, radius: float = 0.03,
             height: float = 0.13) -> ObjectConfig:
    return ObjectConfig(name=name, kind="cylinder", shape="cylinder", size=[radius, height], x=x,
                        y=y)


def touching_scene(gap: float = 0.0) -> Scenario:
    """Two boxes touching front to back, and a box touching the target cylinder in front of it
    (its only blocker). `gap` < 0 pushes each front object into the one behind by -gap (m)."""
    return Scenario(name="touching", objects=[
        box("front_box", 0.10, 0.12),
        box("back_box", 0.15 + gap, 0.12, height=0.12),  # its front face on front_box's back face
        box("blocker", 0.195, -0.08),
        cylinder("target", 0.25 + gap, -0.08),  # touches the blocker's back face
    ], target="target")
