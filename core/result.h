#pragma once
// Expected failures (bad input, limits) travel as values; broken contracts throw (style.md).
#include <string>
#include <utility>
#include <variant>

namespace textond {

enum class ErrorCode {
    invalid_argument, // a parameter out of range, a malformed request (HTTP 400)
    too_large,        // over a size or pixel budget (413)
    unsupported,      // a format we do not read (415)
    unprocessable,    // well-formed but unusable: corrupt, truncated, NaN (422)
    not_found,        // unknown file or id (404)
    io,               // the filesystem failed us (500)
    no_space,         // the disk (or quota, or file-size limit) is full (507)
    unavailable,      // a service we depend on (the shared store) cannot be reached (503)
    cancelled,        // abandoned: the client left or the request's deadline passed (503)
    internal,
};

const char* to_string(ErrorCode code);

struct Error {
    ErrorCode code = ErrorCode::internal;
    std::string message;
};

template <class T> class Result {
public:
    Result(T value) : m_v(std::move(value)) {}
    Result(Error error) : m_v(std::move(error)) {}
    bool ok() const { return m_v.index() == 0; }
    explicit operator bool() const { return ok(); }
    T& value() & { return std::get<0>(m_v); }
    const T& value() const& { return std::get<0>(m_v); }
    T&& value() && { return std::get<0>(std::move(m_v)); }
    const Error& error() const { return std::get<1>(m_v); }

private:
    std::variant<T, Error> m_v;
};

inline Error make_error(ErrorCode code, std::string message) {
    return {code, std::move(message)};
}

} // namespace textond
