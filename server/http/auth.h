#pragma once
// The API key that guards writes.
#include "server/http/imports.h"

#include <httplib.h>

#include <string>

namespace textond::http {

// Writes need `Authorization: Bearer <api_key>` when an API key is set (compared in constant
// time); 401 with WWW-Authenticate sent when not.
bool authorised(const std::string& api_key, const httplib::Request& req, httplib::Response& res);

} // namespace textond::http
