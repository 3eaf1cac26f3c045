// The console's gate (host/ui/access): token, Host and Origin.
#include <gtest/gtest.h>

#include <set>
#include <vector>

#include "ui/access.hpp"

namespace piezoloop::ui {
namespace {

const std::string kToken = "00112233445566778899aabbccddeeff";

TEST(UiAccess, SessionTokenIs128RandomBits) {
    std::set<std::string> seen;
    for (int i = 0; i < 100; ++i) {
        const std::string t = random_hex(kTokenBytes);
        ASSERT_EQ(t.size(), 32u);
        EXPECT_EQ(t.find_first_not_of("0123456789abcdef"), std::string::npos);
        seen.insert(t);
    }
    EXPECT_EQ(seen.size(), 100u);  // a repeat among 100 draws of 2^128 would be a broken source
}

TEST(UiAccess, TheRightTokenFromThisMachineIsLetIn) {
    const AccessRules r = access_rules(kToken, 8765, "127.0.0.1");
    EXPECT_TRUE(check_access(r, "127.0.0.1:8765", std::nullopt, kToken).ok());
    EXPECT_TRUE(check_access(r, "localhost:8765", std::nullopt, kToken).ok());
    EXPECT_TRUE(check_access(r, "LocalHost:8765", std::string("http://localhost:8765"), kToken).ok());
    EXPECT_TRUE(check_access(r, "127.0.0.1:8765", std::string("http://127.0.0.1:8765"), kToken).ok());
}

TEST(UiAccess, NoOrAnotherTokenIsRefused) {
    const AccessRules r = access_rules(kToken, 8765, "127.0.0.1");
    for (const std::string& t : std::vector<std::string>{std::string(), std::string("0"), kToken.substr(0, 31), kToken + "0",
                                std::string("00112233445566778899aabbccddeefe")}) {
        const Verdict v = check_access(r, "127.0.0.1:8765", std::nullopt, t);
        EXPECT_EQ(v.http_status, 403) << t;
        EXPECT_NE(v.reason.find("token"), std::string::npos) << v.reason;
    }
}

TEST(UiAccess, AForeignHostIsRefusedEvenWithTheToken) {
    // DNS rebinding: another site's name resolving to 127.0.0.1.
    const AccessRules r = access_rules(kToken, 8765, "127.0.0.1");
    for (const std::string& h : std::vector<std::string>{"evil.example:8765", "127.0.0.1:8766", "127.0.0.1", "", "localhost.evil:8765",
                                "192.168.1.5:8765"}) {
        const Verdict v = check_access(r, h, std::nullopt, kToken);
        EXPECT_EQ(v.http_status, 403) << h;
        EXPECT_NE(v.reason.find("Host"), std::string::npos) << v.reason;
    }
}

TEST(UiAccess, AForeignOriginIsRefusedEvenWithTheToken) {
    const AccessRules r = access_rules(kToken, 8765, "127.0.0.1");
    for (const std::string& o : std::vector<std::string>{"http://evil.example", "null", "https://127.0.0.1:8765", "http://127.0.0.1:8766",
                                "http://localhost:8765.evil.example", "file://", ""}) {
        const Verdict v = check_access(r, "127.0.0.1:8765", o, kToken);
        EXPECT_EQ(v.http_status, 403) << o;
        EXPECT_NE(v.reason.find("Origin"), std::string::npos) << v.reason;
    }
}

TEST(UiAccess, ABindAddressIsAcceptedAsHostOnlyWhenBound) {
    EXPECT_FALSE(check_access(access_rules(kToken, 80, "127.0.0.1"), "10.0.0.7:80", std::nullopt, kToken).ok());
    const AccessRules r = access_rules(kToken, 80, "10.0.0.7");
    EXPECT_TRUE(check_access(r, "10.0.0.7:80", std::string("http://10.0.0.7:80"), kToken).ok());
    // A wildcard bind names no host: the machine's own names stay the only ones.
    const AccessRules any = access_rules(kToken, 80, "0.0.0.0");
    EXPECT_FALSE(check_access(any, "0.0.0.0:80", std::nullopt, kToken).ok());
}

TEST(UiAccess, SameSecretComparesWholeStrings) {
    EXPECT_TRUE(same_secret("abc", "abc"));
    EXPECT_FALSE(same_secret("abc", "abd"));
    EXPECT_FALSE(same_secret("abc", "ab"));
    EXPECT_FALSE(same_secret("abc", ""));
    EXPECT_FALSE(same_secret("", "abc"));
    EXPECT_TRUE(same_secret("", ""));
}

}  // namespace
}  // namespace piezoloop::ui
