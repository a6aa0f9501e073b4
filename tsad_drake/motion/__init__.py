"""Motion level: each pick-and-place as IK keyframes + KinematicTrajectoryOptimization segments,
densely re-checked with SceneGraphCollisionChecker; plan.json `motion` export, model directives,
Meshcat replay. Entry points: `verify_plan`, `motion_check`, `motion_section`,
`validate_motion_section`, `write_scene_directives`, `write_replay_html`, `replay_collisions`.
"""
