// docs/protocol.md against the message declarations
// (common/piezoloop/link/messages.hpp): the table of message types holds
// every type with its id and no id in use is called reserved, every body
// size the document states is the encoded one, and the protocol version is
// the declared one wherever the document states it.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "piezoloop/link/messages.hpp"

using namespace piezoloop::link;

namespace {

std::string protocol_doc() {
    std::ifstream f(std::string(PIEZOLOOP_GOLDEN_DIR) + "/../../docs/protocol.md");
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

std::string hex(MsgType t) {
    char b[8];
    std::snprintf(b, sizeof b, "0x%02X", static_cast<unsigned>(t));
    return b;
}

struct TypeName {
    MsgType type;
    const char* name;
};
// Every MsgType, by the name the document uses.
constexpr std::array<TypeName, 25> kTypes = {{
    {MsgType::kHello, "Hello"},
    {MsgType::kGetStatus, "GetStatus"},
    {MsgType::kGetParams, "GetParams"},
    {MsgType::kSetParams, "SetParams"},
    {MsgType::kArm, "Arm"},
    {MsgType::kDisarm, "Disarm"},
    {MsgType::kClearTrip, "ClearTrip"},
    {MsgType::kStartWave, "StartWave"},
    {MsgType::kStopWave, "StopWave"},
    {MsgType::kStreamStart, "StreamStart"},
    {MsgType::kSetpoints, "Setpoints"},
    {MsgType::kStreamStop, "StreamStop"},
    {MsgType::kRecorderArm, "RecorderArm"},
    {MsgType::kRecorderStop, "RecorderStop"},
    {MsgType::kStartExcitation, "StartExcitation"},
    {MsgType::kStopExcitation, "StopExcitation"},
    {MsgType::kSave, "Save"},
    {MsgType::kLoad, "Load"},
    {MsgType::kForget, "Forget"},
    {MsgType::kAck, "Ack"},
    {MsgType::kHelloReply, "HelloReply"},
    {MsgType::kStatusReply, "StatusReply"},
    {MsgType::kParamsReply, "ParamsReply"},
    {MsgType::kSetpointAck, "SetpointAck"},
    {MsgType::kLogBlock, "LogBlock"},
}};

template <class M>
std::size_t body_size(const M& m = {}) {
    std::array<uint8_t, kMaxPayload> buf{};
    Writer w{std::span<uint8_t>(buf)};
    m.write(w);
    EXPECT_TRUE(w.ok());
    return w.size();
}

// The size stated in the section that starts at `heading`: the first
// "N bytes" after it.
std::size_t stated_size(const std::string& doc, const std::string& heading) {
    const std::size_t at = doc.find(heading);
    EXPECT_NE(at, std::string::npos) << heading;
    if (at == std::string::npos) return 0;
    std::smatch m;
    const std::string rest = doc.substr(at, 600);
    if (!std::regex_search(rest, m, std::regex(R"((\d+) bytes)"))) return 0;
    return static_cast<std::size_t>(std::stoul(m[1]));
}

}  // namespace

TEST(ProtocolDoc, TheTypeTableHoldsEveryTypeAndNoneInUseIsReserved) {
    const std::string doc = protocol_doc();
    ASSERT_FALSE(doc.empty());
    std::set<unsigned> in_use;
    for (const TypeName& t : kTypes) {
        in_use.insert(static_cast<unsigned>(t.type));
        EXPECT_NE(doc.find("| " + hex(t.type) + " | " + t.name + " |"), std::string::npos)
            << t.name << " (" << hex(t.type) << ") is not in the table of message types";
    }
    in_use.insert(static_cast<unsigned>(MsgType::kError));
    EXPECT_NE(doc.find("| 0xFF | Error |"), std::string::npos);
    // Sentences that call ids reserved name none in use.
    const std::regex reserved(R"(((?:0x[0-9A-Fa-f]{2}(?:,| and| or)?\s*)+)(?:is|are) reserved)");
    for (auto it = std::sregex_iterator(doc.begin(), doc.end(), reserved); it != std::sregex_iterator(); ++it) {
        const std::string ids = (*it)[1];
        const std::regex id(R"(0x([0-9A-Fa-f]{2}))");
        for (auto j = std::sregex_iterator(ids.begin(), ids.end(), id); j != std::sregex_iterator(); ++j)
            EXPECT_EQ(in_use.count(std::stoul((*j)[1], nullptr, 16)), 0u) << "reserved, but in use: 0x" << (*j)[1];
    }
}

TEST(ProtocolDoc, EveryStatedBodySizeIsTheEncodedOne) {
    const std::string doc = protocol_doc();
    EXPECT_EQ(stated_size(doc, "### HelloReply (0x81)"), body_size<HelloReply>());
    EXPECT_EQ(stated_size(doc, "### StatusReply (0x82)"), body_size<StatusReply>());
    EXPECT_EQ(stated_size(doc, "SetpointAck (0x84)"), body_size<SetpointAck>());
    EXPECT_EQ(stated_size(doc, "Error, "), body_size<ErrorReply>());
    EXPECT_EQ(stated_size(doc, "StartExcitation (0x0F) starts"), body_size<StartExcitation>());
}

TEST(ProtocolDoc, TheVersionIsTheDeclaredOne) {
    const std::string doc = protocol_doc();
    const std::string v = std::to_string(kProtocolVersion);
    EXPECT_NE(doc.find("# piezoloop link protocol (version " + v + ")"), std::string::npos);
    EXPECT_NE(doc.find("the header carries the protocol version (" + v + ";"), std::string::npos);
    EXPECT_NE(doc.find("| 0 | protocol_version | u8 | " + v + " |"), std::string::npos)
        << "HelloReply's protocol_version row";
}
