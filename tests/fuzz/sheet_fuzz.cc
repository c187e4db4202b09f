// libFuzzer target: process sheets (common/procman/sheet.h, bot-procman's format) as
// kestrel-procman reads them (docs/design.md §7.7). Properties, beyond no crash and no sanitizer
// report: a refused sheet throws std::runtime_error naming "FILE:LINE: "; an accepted sheet,
// printed back in canonical form, parses to the same commands and scripts.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "common/procman/sheet.h"

namespace {

using kestrel::procman::Command;
using kestrel::procman::ScriptAction;
using kestrel::procman::Sheet;

void Require(bool condition) {
  if (!condition) std::abort();
}

std::string Quote(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\' || c == '\n') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string Print(const Sheet& sheet) {
  std::string out;
  for (const Command& c : sheet.commands) {
    std::string open;
    std::string close;
    if (!c.group.empty()) {
      size_t start = 0;
      while (true) {
        const size_t slash = c.group.find('/', start);
        open += "group " + Quote(c.group.substr(start, slash - start)) + " {\n";
        close += "}\n";
        if (slash == std::string::npos) break;
        start = slash + 1;
      }
    }
    out += open + "cmd " + Quote(c.id) + " {\n  exec = " + Quote(c.exec) +
           ";\n  host = " + Quote(c.host) +
           ";\n  auto_respawn = " + (c.auto_respawn ? "\"true\"" : "\"false\"") +
           ";\n  stop_signal = " + std::to_string(c.stop_signal) +
           ";\n  stop_time_allowed = " + std::to_string(static_cast<int>(c.stop_time_allowed_s)) +
           ";\n}\n" + close;
  }
  for (const auto& s : sheet.scripts) {
    out += "script " + Quote(s.name) + " {\n";
    for (const ScriptAction& a : s.actions) {
      const std::string target =
          std::string(a.target_is_group ? "group " : "cmd ") + Quote(a.target);
      switch (a.kind) {
        case ScriptAction::Kind::kStart:
        case ScriptAction::Kind::kStop:
        case ScriptAction::Kind::kRestart:
          out += std::string(a.kind == ScriptAction::Kind::kStart  ? "start "
                             : a.kind == ScriptAction::Kind::kStop ? "stop "
                                                                   : "restart ") +
                 target + (a.wait_status.empty() ? "" : " wait " + Quote(a.wait_status));
          break;
        case ScriptAction::Kind::kWaitMs:
          out += "wait ms " + std::to_string(a.wait_ms);
          break;
        case ScriptAction::Kind::kWaitStatus:
          out += "wait " + target + " status " + Quote(a.wait_status);
          break;
        case ScriptAction::Kind::kRunScript:
          out += "run_script " + Quote(a.target);
          break;
      }
      out += ";\n";
    }
    out += "}\n";
  }
  return out;
}

bool SameCommands(const Sheet& a, const Sheet& b) {
  if (a.commands.size() != b.commands.size()) return false;
  for (size_t i = 0; i < a.commands.size(); ++i) {
    const Command& x = a.commands[i];
    const Command& y = b.commands[i];
    if (x.id != y.id || x.exec != y.exec || x.host != y.host || x.group != y.group ||
        x.auto_respawn != y.auto_respawn || x.stop_signal != y.stop_signal ||
        x.stop_time_allowed_s != y.stop_time_allowed_s) {
      return false;
    }
  }
  return true;
}

bool SameScripts(const Sheet& a, const Sheet& b) {
  if (a.scripts.size() != b.scripts.size()) return false;
  for (size_t i = 0; i < a.scripts.size(); ++i) {
    if (a.scripts[i].name != b.scripts[i].name ||
        a.scripts[i].actions.size() != b.scripts[i].actions.size()) {
      return false;
    }
    for (size_t k = 0; k < a.scripts[i].actions.size(); ++k) {
      const ScriptAction& x = a.scripts[i].actions[k];
      const ScriptAction& y = b.scripts[i].actions[k];
      if (x.kind != y.kind || x.target_is_group != y.target_is_group || x.target != y.target ||
          x.wait_status != y.wait_status || x.wait_ms != y.wait_ms) {
        return false;
      }
    }
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  Sheet sheet;
  try {
    sheet = kestrel::procman::ParseSheet(text, "fuzz.procman");
  } catch (const std::runtime_error& e) {
    Require(std::string(e.what()).rfind("fuzz.procman:", 0) == 0);
    return 0;
  }
  for (const Command& c : sheet.commands) {
    Require(sheet.FindCommand(c.id) != nullptr && !c.exec.empty() && !c.host.empty());
    Require(c.stop_signal >= 1 && c.stop_signal <= 64);
  }
  const std::string printed = Print(sheet);
  Sheet again;
  try {
    again = kestrel::procman::ParseSheet(printed, "printed.procman");
  } catch (const std::runtime_error&) {
    std::abort();  // an accepted sheet, printed back, must parse
  }
  Require(SameCommands(sheet, again) && SameScripts(sheet, again));
  return 0;
}
