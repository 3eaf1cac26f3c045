// `piezoloop schema`: the parameter tree as JSON Schema (draft 2020-12), the
// contract other clients use to name parameters; `--markdown`: the tables of
// docs/protocol.md, section 3; `--messages`: its table of message types;
// `--layout NAME`: a message's layout table.
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "link/params_schema.hpp"
#include "link/protocol_tables.hpp"

namespace piezoloop::cli {

namespace {

void add_schema(CLI::App& app) {
    auto markdown = std::make_shared<bool>(false);
    CLI::App* cmd = app.add_subcommand(
        "schema", "Print the board's parameter groups as JSON Schema (draft 2020-12): every field's type, unit, "
                  "range, default and whether it is limit-critical.");
    auto messages = std::make_shared<bool>(false);
    auto layout = std::make_shared<std::string>();
    CLI::Option* md = cmd->add_flag("--markdown", *markdown, "print the Markdown tables of docs/protocol.md instead");
    CLI::Option* msg = cmd->add_flag("--messages", *messages,
                  "print the Markdown table of message types of docs/protocol.md, section 2, instead")
        ->excludes(md);
    std::string names;
    for (const std::string& n : hostlink::message_layout_names()) names += (names.empty() ? "" : ", ") + n;
    cmd->add_option("--layout", *layout,
                    "print the Markdown layout table of docs/protocol.md, section 3, of one message instead: " + names)
        ->excludes(md)
        ->excludes(msg);
    cmd->callback([markdown, messages, layout] {
        if (!layout->empty())
            std::cout << hostlink::message_layout_markdown(*layout);
        else if (*messages)
            std::cout << hostlink::message_types_markdown();
        else if (*markdown)
            std::cout << hostlink::parameter_tables_markdown();
        else
            std::cout << hostlink::parameter_schema().dump(2) << "\n";
    });
}

const bool registered_schema = register_command(65, add_schema);

}  // namespace

}  // namespace piezoloop::cli
