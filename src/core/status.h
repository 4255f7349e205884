/// @file status.h
/// @brief Failure channels: `Error` exceptions for set-up and I/O, `Status` values for per-frame
/// outcomes that cross threads. Both map onto the contract's exit codes.
#pragma once

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

namespace aoscan {

/// Process exit codes of the contract.
enum class ExitCode : int {
  kOk = 0,
  kFailure = 1,   ///< anything else
  kUsage = 2,     ///< usage or configuration error
  kBadInput = 3,  ///< missing, unreadable or inconsistent source data
  kDevice = 4,    ///< camera / device error
};

/// Exception for set-up and I/O failures; the message is one line naming the file (and frame).
class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

inline Error usage_error(const std::string& message) { return Error(ExitCode::kUsage, message); }
inline Error input_error(const std::string& message) { return Error(ExitCode::kBadInput, message); }
inline Error device_error(const std::string& message) { return Error(ExitCode::kDevice, message); }

/// `s` on one line: every line break ('\n', '\r') becomes a space. Error messages go to stderr as
/// one line, also when they quote a library's multi-line text.
inline std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

/// Throws Error(kFailure) "PATH: cannot write: <errno text>" (EIO's text when errno is not set).
[[noreturn]] inline void throw_write_failed(const std::string& path) {
  throw Error(ExitCode::kFailure, path + ": cannot write: " + std::strerror(errno ? errno : EIO));
}

/// Outcome of a per-frame operation (a read, a stage step). Cheap to copy; never thrown.
class Status {
 public:
  enum class Code {
    kOk,
    kEndOfStream,   ///< the source has no more frames
    kCorruptFrame,  ///< this frame is unusable; the stream goes on (counted skip)
    kBadInput,      ///< the source cannot go on (exit 3)
    kDeviceLost,    ///< the camera went away (exit 4)
    kInternal,      ///< a bug or an unexpected failure (exit 1)
  };

  Status() = default;
  Status(Code code, std::string message) : code_(code), message_(std::move(message)) {}
  static Status ok() { return {}; }
  static Status end_of_stream() { return {Code::kEndOfStream, "end of stream"}; }
  static Status corrupt_frame(std::string m) { return {Code::kCorruptFrame, std::move(m)}; }
  static Status bad_input(std::string m) { return {Code::kBadInput, std::move(m)}; }
  static Status device_lost(std::string m) { return {Code::kDeviceLost, std::move(m)}; }
  static Status internal(std::string m) { return {Code::kInternal, std::move(m)}; }

  bool is_ok() const { return code_ == Code::kOk; }
  Code code() const { return code_; }
  const std::string& message() const { return message_; }

  /// Exit code for a status that ends the run (kOk and kEndOfStream end cleanly).
  ExitCode exit_code() const {
    switch (code_) {
      case Code::kOk:
      case Code::kEndOfStream:
        return ExitCode::kOk;
      case Code::kCorruptFrame:
      case Code::kBadInput:
        return ExitCode::kBadInput;
      case Code::kDeviceLost:
        return ExitCode::kDevice;
      case Code::kInternal:
        break;
    }
    return ExitCode::kFailure;
  }

 private:
  Code code_ = Code::kOk;
  std::string message_;
};

}  // namespace aoscan
