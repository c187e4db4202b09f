#pragma once
/// @file
/// Process sheets in bot-procman's configuration file format (libbot2 bot2-procman,
/// "Configuration files"): `cmd "id" { exec = "..."; host = "..."; auto_respawn = "true";
/// stop_signal = 15; stop_time_allowed = 7; }`, nested `group "name" { ... }` and
/// `script "name" { start cmd "x" wait "running"; wait ms 500; ... }`, `#` comments.
/// Malformed sheets are refused with the file and line number.

#include <string>
#include <vector>

namespace kestrel::procman {

/// One command of a sheet.
struct Command {
  std::string id;                 ///< unique command id ("nickname")
  std::string exec;               ///< shell command line (bash-style: env prefixes allowed)
  std::string host;               ///< deputy (runner) that runs it
  std::string group;              ///< enclosing groups joined by '/', "" at top level
  bool auto_respawn{false};       ///< restart when it exits while desired running
  int stop_signal{2};             ///< signal sent to stop it (default SIGINT, as procman)
  double stop_time_allowed_s{7};  ///< then SIGKILL after this long (default 7 s, as procman)
  int line{0};                    ///< line of its `cmd` in the sheet
};

/// One action of a script.
struct ScriptAction {
  enum class Kind { kStart, kStop, kRestart, kWaitMs, kWaitStatus, kRunScript };
  Kind kind{Kind::kStart};
  bool target_is_group{false};  ///< `group "x"` rather than `cmd "x"`
  std::string target;           ///< command id, group path or script name
  std::string wait_status;      ///< "", "running" or "stopped"
  int wait_ms{0};
  int line{0};
};

struct Script {
  std::string name;
  std::vector<ScriptAction> actions;
};

struct Sheet {
  std::string file;
  std::vector<Command> commands;
  std::vector<Script> scripts;

  /// The commands with this id (nullptr if none).
  [[nodiscard]] const Command* FindCommand(const std::string& id) const;
  /// The commands in group `path` or any of its subgroups.
  [[nodiscard]] std::vector<const Command*> CommandsInGroup(const std::string& path) const;
  [[nodiscard]] const Script* FindScript(const std::string& name) const;
};

/// Parses sheet text. @throws std::runtime_error "FILE:LINE: reason" on any malformed input,
/// unknown attribute, missing exec/host, duplicate command id, or a script naming an unknown
/// command, group or script.
[[nodiscard]] Sheet ParseSheet(const std::string& text, const std::string& file_name);
/// Reads and parses a file. @throws std::runtime_error
[[nodiscard]] Sheet LoadSheet(const std::string& path);

}  // namespace kestrel::procman
