#include "ui/access.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <stdexcept>

namespace piezoloop::ui {

std::string random_hex(std::size_t bytes) {
    std::ifstream in("/dev/urandom", std::ios::binary);
    std::string raw(bytes, '\0');
    if (!in.read(raw.data(), static_cast<std::streamsize>(bytes)))
        throw std::runtime_error("cannot read /dev/urandom for the session token");
    static const char* const kDigits = "0123456789abcdef";
    std::string out;
    out.reserve(2 * bytes);
    for (const char c : raw) {
        const auto b = static_cast<unsigned char>(c);
        out += kDigits[b >> 4];
        out += kDigits[b & 0xf];
    }
    return out;
}

AccessRules access_rules(std::string token, int port, const std::string& bind_address) {
    AccessRules r;
    r.token = std::move(token);
    const std::string p = ":" + std::to_string(port);
    r.hosts = {"127.0.0.1" + p, "localhost" + p};
    if (bind_address != "127.0.0.1" && bind_address != "localhost" && bind_address != "0.0.0.0" &&
        bind_address != "::" && !bind_address.empty())
        r.hosts.push_back((bind_address.find(':') != std::string::npos ? "[" + bind_address + "]" : bind_address) + p);
    return r;
}

bool same_secret(const std::string& a, const std::string& b) {
    unsigned diff = a.size() == b.size() ? 0u : 1u;
    for (std::size_t i = 0; i < a.size(); ++i)
        diff |= static_cast<unsigned char>(a[i]) ^ static_cast<unsigned char>(b.empty() ? 0 : b[i % b.size()]);
    return diff == 0;
}

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

bool known_host(const AccessRules& rules, const std::string& host) {
    const std::string h = lower(host);
    return std::find(rules.hosts.begin(), rules.hosts.end(), h) != rules.hosts.end();
}

}  // namespace

Verdict check_access(const AccessRules& rules, const std::string& host, const std::optional<std::string>& origin,
                     const std::string& token) {
    if (!known_host(rules, host)) return {403, "Host '" + host + "' is not this console's address"};
    if (origin) {
        const std::string o = lower(*origin);
        const std::string prefix = "http://";
        if (o.rfind(prefix, 0) != 0 || !known_host(rules, o.substr(prefix.size())))
            return {403, "Origin '" + *origin + "' is not this console's page"};
    }
    if (token.empty()) return {403, "no session token (open the URL piezoloop ui printed)"};
    if (!same_secret(token, rules.token)) return {403, "wrong session token"};
    return {};
}

}  // namespace piezoloop::ui
