#include "drivers/serial/pseudo_terminal.h"

#include <fcntl.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace kestrel {

PseudoTerminal::PseudoTerminal(std::string link_path) : link_path_(std::move(link_path)) { Plug(); }

PseudoTerminal::~PseudoTerminal() { Unplug(); }

void PseudoTerminal::Plug() {
  if (master_fd_ >= 0) return;
  termios raw{};
  cfmakeraw(&raw);  // the slave must not echo what the driver writes back to the emulator
  char name[256] = {};
  if (openpty(&master_fd_, &slave_fd_, name, &raw, nullptr) != 0) {
    throw std::runtime_error(std::string("openpty: ") + std::strerror(errno));
  }
  ::fcntl(master_fd_, F_SETFL, ::fcntl(master_fd_, F_GETFL) | O_NONBLOCK);
  ::fcntl(master_fd_, F_SETFD, FD_CLOEXEC);
  ::fcntl(slave_fd_, F_SETFD, FD_CLOEXEC);
  slave_path_ = name;
  if (!link_path_.empty()) {
    const std::string tmp = link_path_ + ".tmp";
    ::unlink(tmp.c_str());
    if (::symlink(slave_path_.c_str(), tmp.c_str()) != 0 ||
        ::rename(tmp.c_str(), link_path_.c_str()) != 0) {
      const std::string error = std::strerror(errno);
      Unplug();
      throw std::runtime_error("cannot link " + link_path_ + " to " + name + ": " + error);
    }
  }
}

void PseudoTerminal::Unplug() {
  if (master_fd_ < 0) return;
  if (!link_path_.empty()) ::unlink(link_path_.c_str());
  ::close(master_fd_);
  ::close(slave_fd_);
  master_fd_ = -1;
  slave_fd_ = -1;
}

}  // namespace kestrel
