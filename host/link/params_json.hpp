// The link's parameter groups as JSON, field names as in docs/protocol.md
// (section 3), enums by name. Reading merges onto an existing group: only
// the keys given change, an unknown key or a value of the wrong kind is an
// error naming "<group>.<key>" (std::invalid_argument), so a typo never
// passes silently. Floats go through double, so every float32 value
// survives get -> JSON -> set bit for bit.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "piezoloop/link/messages.hpp"

namespace piezoloop::hostlink {

nlohmann::json to_json(const link::FeedforwardParams& g);
nlohmann::json to_json(const link::FeedbackParams& g);
nlohmann::json to_json(const link::RepetitiveParams& g);
nlohmann::json to_json(const link::LimitsParams& g);
nlohmann::json to_json(const link::TrajectoryParams& g);
nlohmann::json to_json(const link::RecorderParams& g);
nlohmann::json to_json(const link::LinkParams& g);
nlohmann::json to_json(const link::InputMatrixParams& g);
nlohmann::json to_json(const link::OutputMatrixParams& g);
nlohmann::json to_json(const link::HelloReply& h);
nlohmann::json to_json(const link::StatusReply& s);
// Axis a's entries of the status (its axes block), named x, y or z.
nlohmann::json axis_status_json(const link::StatusReply& s, int a);

void merge_json(const nlohmann::json& j, link::FeedforwardParams& g);
void merge_json(const nlohmann::json& j, link::FeedbackParams& g);
void merge_json(const nlohmann::json& j, link::RepetitiveParams& g);
void merge_json(const nlohmann::json& j, link::LimitsParams& g);
void merge_json(const nlohmann::json& j, link::TrajectoryParams& g);
void merge_json(const nlohmann::json& j, link::RecorderParams& g);
void merge_json(const nlohmann::json& j, link::LinkParams& g);
void merge_json(const nlohmann::json& j, link::InputMatrixParams& g);
void merge_json(const nlohmann::json& j, link::OutputMatrixParams& g);

// "feedforward", "feedback", "rc", "limits", "trajectory", "recorder" -> group;
// throws std::invalid_argument listing the names for anything else.
link::ParamGroup parse_group(const std::string& name);

// Signal names r, y, e, u, u_ff, u_fb, u_rc -> ids (std::invalid_argument otherwise).
uint8_t parse_signal(const std::string& name);
const char* waveform_name(Waveform w);
Waveform parse_waveform(const std::string& name);

}  // namespace piezoloop::hostlink
