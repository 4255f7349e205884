/// @file config_fuzz.cpp
/// @brief libFuzzer target: a YAML configuration file (`--config`), loaded and validated.
#include "fuzz/fuzz_input.h"
#include "pipeline/config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  static fuzz::InputFile file("config.yaml");
  const std::string& path = file.write(data, size);
  Config config;
  if (fuzz::expect_errors(path, [&] { load_config_file(config, path); }))
    fuzz::expect_errors("configuration", [&] { validate_config(config); });
  return 0;
}
