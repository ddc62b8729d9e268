#pragma once
// The basal resistance laws of the thickness-integrated model: one line per law (its FrictionModel is defined
// in its own file in this folder).
#define RUNOUT_BASAL_FRICTIONS(X) \
  X(coulomb_friction)             \
  X(voellmy_friction)
