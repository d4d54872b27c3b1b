// Result<T>: a value or an error, for setup and parsing paths that must
// report a reason instead of aborting (vk-bootstrap style). An error of bad
// input names where it is ("resolutions[2]", "passes.shading.width"), so that
// an HTTP answer can report the field without reading it back out of text.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

namespace tally {

class Error {
 public:
  explicit Error(std::string message) : message_(std::move(message)), text_(message_) {}
  Error(std::string field, std::string message)
      : field_(std::move(field)),
        message_(std::move(message)),
        text_(field_.empty() ? message_ : field_ + ": " + message_) {}

  // Where the problem is, as a path into the input; empty when no field is to blame.
  const std::string& field() const { return field_; }
  // What is wrong there, without the field.
  const std::string& message() const { return message_; }
  // "field: message" (or the message alone): what is printed and answered.
  const std::string& text() const { return text_; }

 private:
  std::string field_;
  std::string message_;
  std::string text_;
};

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : data_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
  Result(Error error) : data_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const { return data_.index() == 0; }
  explicit operator bool() const { return ok(); }

  const T& value() const& { check(); return std::get<0>(data_); }
  T& value() & { check(); return std::get<0>(data_); }
  T&& value() && { check(); return std::get<0>(std::move(data_)); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

  // The error's text, "field: message".
  const std::string& error() const { return std::get<1>(data_).text(); }
  // The error with its field and message apart.
  const Error& failure() const { return std::get<1>(data_); }

 private:
  void check() const {
    if (!ok()) throw std::logic_error("Result accessed without value: " + error());
  }
  std::variant<T, Error> data_;
};

inline Error makeError(std::string message) { return Error(std::move(message)); }

}  // namespace tally
