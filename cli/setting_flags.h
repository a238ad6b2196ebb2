// Command-line flags from a setting table (pipeline/settings.h): one flag per row that
// names one, parsed into a scratch copy of the options (shown with its defaults in
// --help). After parsing, Apply() sets the proto field of every flag that was given in
// a settings message over whatever it held (a session file, an options file), so that
// a flag overrides a file for every option, with no hand-kept list of flags.
#pragma once

#include <google/protobuf/message.h>

#include <CLI/CLI.hpp>
#include <memory>
#include <utility>
#include <vector>

#include "pipeline/settings.h"

namespace dome::cli {

template <class Options>
class SettingFlags {
 public:
  SettingFlags(CLI::App* cmd, const std::vector<pipeline::SettingField<Options>>& fields,
               const Options& defaults = {})
      : scratch_(std::make_unique<Options>(defaults)) {
    for (const auto& field : fields) {
      if (*field.flag == '\0') continue;
      CLI::Option* option = std::visit(
          [&](auto member) -> CLI::Option* {
            auto& value = member(*scratch_);
            if constexpr (std::is_same_v<std::decay_t<decltype(value)>, bool>) {
              return cmd->add_flag(field.flag, value, field.help);
            } else {
              return cmd->add_option(field.flag, value, field.help)->capture_default_str();
            }
          },
          field.member);
      bound_.emplace_back(option, &field);
    }
  }

  // Sets `settings`' field of every flag given on the command line.
  void Apply(google::protobuf::Message* settings) const {
    for (const auto& [option, field] : bound_) {
      if (option->count() > 0) pipeline::SetProtoField(*field, *scratch_, settings);
    }
  }

 private:
  std::unique_ptr<Options> scratch_;  // CLI11 writes here: a stable address
  std::vector<std::pair<CLI::Option*, const pipeline::SettingField<Options>*>> bound_;
};

}  // namespace dome::cli
