"""The acrobot's physics without a simulator: parameters, equations of motion, the step."""
