#pragma once
// The API key that guards writes, and tells its holder apart from other clients.
#include "server/http/imports.h"

#include <httplib.h>

#include <string>

namespace textond::http {

// True when an API key is set and the request carries `Authorization: Bearer <api_key>`
// (compared in constant time).
bool holds_api_key(const std::string& api_key, const httplib::Request& req);

// Writes need the API key's holder when a key is set; 401 with WWW-Authenticate sent when not.
bool authorised(const std::string& api_key, const httplib::Request& req, httplib::Response& res);

} // namespace textond::http
