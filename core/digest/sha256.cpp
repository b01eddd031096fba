#include "circtest/core/sha256.hpp"

#include <fmt/format.h>
#include <openssl/evp.h>

#include <memory>

#include "circtest/core/error.hpp"
#include "circtest/core/input_file.hpp"
#include "circtest/core/trace_keys.hpp"

namespace circtest {

namespace {

std::string hex_of(const unsigned char* digest, unsigned int size) {
  std::string hex;
  for (unsigned int i = 0; i < size; ++i) hex += fmt::format("{:02x}", digest[i]);
  return hex;
}

}  // namespace

std::string sha256_hex(std::string_view data) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_Digest(data.data(), data.size(), digest, &size, EVP_sha256(), nullptr) != 1) {
    throw Error(ExitCode::internal, "SHA-256 failed");
  }
  return hex_of(digest, size);
}

// Streamed: a trace of any length is hashed in blocks, never held whole.
std::string sha256_of_file(const std::string& path) {
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1) {
    throw Error(ExitCode::internal, "SHA-256 failed");
  }
  for_each_input_block(path, [&](std::string_view block) {
    if (EVP_DigestUpdate(ctx.get(), block.data(), block.size()) != 1) {
      throw Error(ExitCode::internal, "SHA-256 failed");
    }
  });
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_DigestFinal_ex(ctx.get(), digest, &size) != 1) {
    throw Error(ExitCode::internal, "SHA-256 failed");
  }
  return hex_of(digest, size);
}

void record_ini_provenance(TraceMetadata& metadata, const std::string& ini_path) {
  std::string digest = sha256_of_file(ini_path);
  metadata.set(meta_key::ini, ini_path);
  metadata.set(meta_key::ini_sha256, std::move(digest));
}

}  // namespace circtest
