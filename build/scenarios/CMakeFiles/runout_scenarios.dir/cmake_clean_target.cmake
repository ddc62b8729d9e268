file(REMOVE_RECURSE
  "librunout_scenarios.a"
)
