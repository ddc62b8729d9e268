#pragma once
// The rheology registration list: one line per model (its RheologyModel is defined in its own file).
#define RUNOUT_RHEOLOGIES(X) \
  X(newtonian_model)         \
  X(bingham_model)           \
  X(hbp_model)               \
  X(friction_hbp_model)      \
  X(mu_i_model)
