// Errors as values. A function that can fail returns Result<T> (or Status for no value);
// the error carries a code and a message that names what failed and where (file, frame, key).
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace ef {

enum class ErrorCode {
  kInvalidArgument,   // a bad option, URI, value or size given by the caller
  kNotFound,          // a file, device or key that does not exist
  kIoError,           // a read or write that failed
  kCorruptData,       // a file whose content is malformed, truncated or inconsistent
  kOutOfRange,        // an index or value outside what is allowed
  kResourceExhausted, // a fixed-size pool, arena or ring that is full
  kUnsupported,       // a feature or format this build does not handle
  kInternal,          // a broken invariant: a bug
};

const char* error_code_name(ErrorCode code);

struct Error {
  ErrorCode code;
  std::string message;
};

// Shorthand constructors: `return ef::error(ErrorCode::kNotFound, "rgb.txt: no such file");`
inline Error error(ErrorCode code, std::string message) { return Error{code, std::move(message)}; }

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}          // NOLINT: implicit by design
  Result(Error err) : v_(std::move(err)) {}          // NOLINT: implicit by design

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & { assert(ok()); return std::get<0>(v_); }
  const T& value() const& { assert(ok()); return std::get<0>(v_); }
  T&& value() && { assert(ok()); return std::get<0>(std::move(v_)); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

  const Error& error() const { assert(!ok()); return std::get<1>(v_); }
  Error&& take_error() { assert(!ok()); return std::get<1>(std::move(v_)); }

 private:
  std::variant<T, Error> v_;
};

// Result of an operation with no value.
class [[nodiscard]] Status {
 public:
  Status() = default;                                  // success
  Status(Error err) : err_(std::move(err)), ok_(false) {}  // NOLINT: implicit by design
  static Status success() { return Status(); }

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const { assert(!ok_); return err_; }
  Error&& take_error() { assert(!ok_); return std::move(err_); }

 private:
  Error err_{ErrorCode::kInternal, {}};
  bool ok_ = true;
};

// "code: message", for printing.
std::string to_string(const Error& err);

}  // namespace ef

// Propagate an error from an expression returning Status or Result<T>.
#define EF_RETURN_IF_ERROR(expr)                       \
  do {                                                 \
    auto ef_status_ = (expr);                          \
    if (!ef_status_.ok()) return ef_status_.take_error(); \
  } while (0)

#define EF_CONCAT_INNER_(a, b) a##b
#define EF_CONCAT_(a, b) EF_CONCAT_INNER_(a, b)
// `EF_ASSIGN_OR_RETURN(auto x, f());` declares x from a Result<T> or returns its error.
#define EF_ASSIGN_OR_RETURN(decl, expr) EF_ASSIGN_OR_RETURN_IMPL_(EF_CONCAT_(ef_result_, __LINE__), decl, expr)
#define EF_ASSIGN_OR_RETURN_IMPL_(tmp, decl, expr) \
  auto tmp = (expr);                               \
  if (!tmp.ok()) return tmp.take_error();          \
  decl = std::move(tmp).value()
