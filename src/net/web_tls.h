#pragma once
/// \file
/// The certificate `lamina serve --web` speaks TLS with (docs/web.md, "A headset off this
/// machine"): read from PEM files (--cert, --key), or made for the session (--self-signed).

#include <string>
#include <vector>

#include "web_server.h"

namespace lamina::net::web {

/// A new P-256 key and a certificate for it, signed by itself, valid from an hour ago for 30 days,
/// naming `hosts` (IP addresses or DNS names) as its subject alternative names.
TlsIdentity self_signed_identity(const std::vector<std::string>& hosts);

/// The certificate (chain) and private key in PEM files.
/// \note Throws lamina::Error (kInvalidInput) naming the file for one that cannot be read or
///   holds no PEM certificate (or key), and for a key that does not match the certificate.
TlsIdentity read_identity(const std::string& certificate_path, const std::string& key_path);

}  // namespace lamina::net::web
