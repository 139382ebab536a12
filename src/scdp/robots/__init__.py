"""Robot models: the Franka Panda (kinematics, IK, MuJoCo model) and the TurtleBot3 Burger."""
