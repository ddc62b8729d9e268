# Empty dependencies file for runout_engine.
# This may be replaced when dependencies are built.
