// Who may talk to the console's web server (`piezoloop ui`): a request
// needs the session token printed with the URL at start, a Host header
// naming this server (127.0.0.1:P, localhost:P, or the --bind address:P),
// and, when the browser sends an Origin, that origin being this server's
// own. Another web page open in the same browser knows no token and has a
// foreign Origin, so it can neither read the stream nor drive the stage;
// DNS rebinding gives a foreign Host and is refused as well.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace piezoloop::ui {

// `bytes` random bytes from /dev/urandom as lowercase hex (std::runtime_error
// when it cannot be read). The session token is 16 bytes: 128 bits.
std::string random_hex(std::size_t bytes);
inline constexpr std::size_t kTokenBytes = 16;

struct AccessRules {
    std::string token;
    std::vector<std::string> hosts;  // Host header values accepted, "name:port"
};

// The rules of a server on `port` bound to `bind_address`: 127.0.0.1:P and
// localhost:P always, the bind address:P too unless it is a wildcard.
AccessRules access_rules(std::string token, int port, const std::string& bind_address);

struct Verdict {
    int http_status = 200;  // 200, or 403 with the reason
    std::string reason;
    bool ok() const { return http_status == 200; }
};

// One request's headers against the rules. `token`: what the request
// presented (query parameter or header), empty when none.
Verdict check_access(const AccessRules& rules, const std::string& host, const std::optional<std::string>& origin,
                     const std::string& token);

// Equal strings, compared in time independent of where they differ.
bool same_secret(const std::string& a, const std::string& b);

}  // namespace piezoloop::ui
