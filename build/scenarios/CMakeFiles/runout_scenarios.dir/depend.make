# Empty dependencies file for runout_scenarios.
# This may be replaced when dependencies are built.
