// self_signed_identity, read_identity (web_tls.h) with OpenSSL 3 (Debian's libssl-dev).
#include "web_tls.h"

#include <fmt/format.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/rand.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include <boost/asio/ip/address.hpp>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>

#include "lamina/core/error.h"

namespace lamina::net::web {
namespace {

template <class T, void (*Free)(T*)>
struct Freer {
  void operator()(T* p) const { Free(p); }
};
using Key = std::unique_ptr<EVP_PKEY, Freer<EVP_PKEY, EVP_PKEY_free>>;
using Cert = std::unique_ptr<X509, Freer<X509, X509_free>>;
using Bio = std::unique_ptr<BIO, Freer<BIO, BIO_free_all>>;

std::string bio_text(BIO* bio) {
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio, &data);
  return std::string(data, static_cast<size_t>(n));
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw invalid_input(path, std::filesystem::exists(path) ? "cannot open the file for reading"
                                                            : "file not found");
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string fingerprint(X509* cert) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  X509_digest(cert, EVP_sha256(), md, &n);
  std::string out;
  for (unsigned int i = 0; i < n; ++i) out += fmt::format("{}{:02X}", i ? ":" : "", md[i]);
  return out;
}

}  // namespace

TlsIdentity self_signed_identity(const std::vector<std::string>& hosts) {
  const Key key(EVP_EC_gen("P-256"));
  const Cert cert(X509_new());
  if (!key || !cert) throw Error(ErrorKind::kInternal, "--self-signed: OpenSSL cannot make a key");
  X509_set_version(cert.get(), 2);
  uint64_t serial = 0;
  RAND_bytes(reinterpret_cast<unsigned char*>(&serial), sizeof serial);
  ASN1_INTEGER_set_uint64(X509_get_serialNumber(cert.get()), serial >> 1);
  X509_gmtime_adj(X509_getm_notBefore(cert.get()), -3600);
  X509_gmtime_adj(X509_getm_notAfter(cert.get()), 30L * 24 * 3600);
  X509_set_pubkey(cert.get(), key.get());
  X509_NAME* name = X509_get_subject_name(cert.get());
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_ASC,
                             reinterpret_cast<const unsigned char*>("lamina serve"), -1, -1, 0);
  X509_set_issuer_name(cert.get(), name);
  std::string san;
  for (const std::string& h : hosts) {
    boost::system::error_code ec;
    boost::asio::ip::make_address(h, ec);
    // Appended piece by piece: GCC 12 reads `"," + std::string(...)` as a memcpy that may
    // overlap itself (-Wrestrict, a false positive of its string inlining).
    if (!san.empty()) san += ',';
    san += ec ? "DNS:" : "IP:";
    san += h;
  }
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, cert.get(), cert.get(), nullptr, nullptr, 0);
  X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, NID_subject_alt_name, san.c_str());
  if (ext == nullptr) throw invalid_input("--self-signed", "cannot name the hosts " + san);
  X509_add_ext(cert.get(), ext, -1);
  X509_EXTENSION_free(ext);
  if (X509_sign(cert.get(), key.get(), EVP_sha256()) == 0)
    throw Error(ErrorKind::kInternal, "--self-signed: OpenSSL cannot sign the certificate");
  const Bio cert_bio(BIO_new(BIO_s_mem())), key_bio(BIO_new(BIO_s_mem()));
  PEM_write_bio_X509(cert_bio.get(), cert.get());
  PEM_write_bio_PrivateKey(key_bio.get(), key.get(), nullptr, nullptr, 0, nullptr, nullptr);
  return {bio_text(cert_bio.get()), bio_text(key_bio.get()), fingerprint(cert.get()),
          "--self-signed"};
}

TlsIdentity read_identity(const std::string& certificate_path, const std::string& key_path) {
  TlsIdentity id;
  id.certificate_pem = read_text(certificate_path);
  id.key_pem = read_text(key_path);
  id.source = certificate_path + " and " + key_path;
  const Bio cert_bio(
      BIO_new_mem_buf(id.certificate_pem.data(), static_cast<int>(id.certificate_pem.size())));
  const Cert cert(PEM_read_bio_X509(cert_bio.get(), nullptr, nullptr, nullptr));
  if (!cert) throw invalid_input(certificate_path, "holds no PEM certificate");
  const Bio key_bio(BIO_new_mem_buf(id.key_pem.data(), static_cast<int>(id.key_pem.size())));
  const Key key(PEM_read_bio_PrivateKey(key_bio.get(), nullptr, nullptr, nullptr));
  if (!key) throw invalid_input(key_path, "holds no PEM private key (or one with a passphrase)");
  if (X509_check_private_key(cert.get(), key.get()) != 1)
    throw invalid_input(key_path, "is not the key of the certificate in " + certificate_path);
  id.fingerprint_sha256 = fingerprint(cert.get());
  return id;
}

}  // namespace lamina::net::web
