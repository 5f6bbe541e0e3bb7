#include "server/io/sha256.h"

#include <openssl/evp.h>

#include <stdexcept>

namespace textond::io {

struct Sha256::Ctx {
    EVP_MD_CTX* md = nullptr;
};

Sha256::Sha256() : m_ctx(std::make_unique<Ctx>()) {
    m_ctx->md = EVP_MD_CTX_new();
    if (!m_ctx->md || EVP_DigestInit_ex(m_ctx->md, EVP_sha256(), nullptr) != 1)
        throw std::runtime_error("SHA-256 unavailable");
}

Sha256::~Sha256() {
    EVP_MD_CTX_free(m_ctx->md);
}

Sha256& Sha256::update(const void* data, std::size_t size) {
    if (EVP_DigestUpdate(m_ctx->md, data, size) != 1) throw std::runtime_error("SHA-256 failed");
    return *this;
}

std::string Sha256::hex() {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    if (EVP_DigestFinal_ex(m_ctx->md, digest, &len) != 1)
        throw std::runtime_error("SHA-256 failed");
    static const char* kHex = "0123456789abcdef";
    std::string out;
    for (unsigned int i = 0; i < len; ++i) {
        out.push_back(kHex[digest[i] >> 4]);
        out.push_back(kHex[digest[i] & 15]);
    }
    return out;
}

std::string sha256_hex(std::string_view data) {
    return Sha256().update(data).hex();
}

} // namespace textond::io
