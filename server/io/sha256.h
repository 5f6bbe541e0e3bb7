#pragma once
// SHA-256 through OpenSSL's libcrypto (already a dependency of Debian's cpp-httplib).
#include <memory>
#include <string>
#include <string_view>

namespace textond::io {

class Sha256 {
public:
    Sha256();
    ~Sha256();
    Sha256(const Sha256&) = delete;
    Sha256& operator=(const Sha256&) = delete;
    Sha256& update(const void* data, std::size_t size);
    Sha256& update(std::string_view s) { return update(s.data(), s.size()); }
    std::string hex(); // finishes the digest

private:
    struct Ctx;
    std::unique_ptr<Ctx> m_ctx;
};

std::string sha256_hex(std::string_view data);

} // namespace textond::io
