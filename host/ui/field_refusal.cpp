#include "ui/field_refusal.hpp"

namespace piezoloop::ui {

FieldRefusal renamed_refusal(const std::string& message, OptionFields options) {
    std::string m = message, field;
    for (const auto& [option, name] : options) {
        const std::string o = option;
        if (field.empty() && m.rfind(o, 0) == 0 && m.size() > o.size() && (m[o.size()] == ':' || m[o.size()] == ' '))
            field = name;
        for (auto p = m.find(o); p != std::string::npos; p = m.find(o, p)) m.replace(p, o.size(), name);
    }
    return FieldRefusal(field, m);
}

}  // namespace piezoloop::ui
