file(REMOVE_RECURSE
  "librunout_engine.a"
)
