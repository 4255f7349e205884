/// @file config_set_fuzz.cpp
/// @brief libFuzzer target: `--set KEY=VALUE` options, one per input line, through load_config
/// (defaults, each `--set`, validation) as the command line uses them.
#include "fuzz/fuzz_input.h"
#include "pipeline/config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  std::vector<std::string> sets;
  std::string current;
  for (std::size_t i = 0; i < size; ++i) {
    if (data[i] == '\n') {
      sets.push_back(current);
      current.clear();
    } else {
      current.push_back(static_cast<char>(data[i]));
    }
  }
  sets.push_back(current);
  try {
    load_config("", sets);
  } catch (const Error& e) {
    if (e.code() != ExitCode::kUsage) fuzz::bug(std::string("unexpected error: ") + e.what());
    const std::string message = e.what();
    if (message.find("--set") == std::string::npos &&
        message.find("configuration") == std::string::npos)
      fuzz::bug("error message names neither --set nor the configuration: " + message);
  }
  return 0;
}
