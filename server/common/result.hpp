// Result<T>: a value or an error message, for setup and parsing paths that
// must report a reason instead of aborting (vk-bootstrap style).
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

namespace tally {

struct Error {
  std::string message;
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

  const std::string& error() const { return std::get<1>(data_).message; }

 private:
  void check() const {
    if (!ok()) throw std::logic_error("Result accessed without value: " + error());
  }
  std::variant<T, Error> data_;
};

inline Error makeError(std::string message) { return Error{std::move(message)}; }

}  // namespace tally
