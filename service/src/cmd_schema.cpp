// `runout schema`: the JSON Schema of a scene, from the models' descriptors.
#include <iostream>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "runout/scenarios/schema.hpp"

namespace runout::cli {

Action add_schema(CLI::App& app) {
  app.add_subcommand("schema", "Print the JSON Schema of a scene, generated from the models' descriptors")
      ->footer("Example:\n  runout schema > scene.schema.json");
  return [](const char*) {
    std::cout << scene_schema().dump(2) << "\n";
    return 0;
  };
}

}  // namespace runout::cli
