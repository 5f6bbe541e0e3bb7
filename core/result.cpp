#include "core/result.h"

namespace textond {

const char* to_string(ErrorCode code) {
    switch (code) {
    case ErrorCode::invalid_argument:
        return "invalid_argument";
    case ErrorCode::too_large:
        return "too_large";
    case ErrorCode::unsupported:
        return "unsupported_media_type";
    case ErrorCode::unprocessable:
        return "unprocessable";
    case ErrorCode::not_found:
        return "not_found";
    case ErrorCode::io:
        return "io_error";
    case ErrorCode::no_space:
        return "no_space";
    case ErrorCode::unavailable:
        return "unavailable";
    case ErrorCode::cancelled:
        return "cancelled";
    case ErrorCode::internal:
        return "internal";
    }
    return "internal";
}

} // namespace textond
