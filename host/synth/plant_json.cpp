#include "synth/plant_json.hpp"

#include <fstream>
#include <stdexcept>

#include "json/json_reader.hpp"

namespace piezoloop::design {
namespace {

using hostjson::Field;

Eigen::MatrixXd read_matrix(const Field& f, Eigen::Index rows, Eigen::Index cols) {
    const size_t r = f.size(static_cast<size_t>(kMaxPlantStates + kMaxPlantSignals));
    if (static_cast<Eigen::Index>(r) != rows)
        f.fail(std::to_string(r) + " rows, expected " + std::to_string(rows));
    Eigen::MatrixXd m(rows, cols);
    for (size_t i = 0; i < r; ++i) {
        const Field row = f.at(i);
        const size_t c = row.size(static_cast<size_t>(kMaxPlantStates + kMaxPlantSignals));
        if (static_cast<Eigen::Index>(c) != cols)
            row.fail(std::to_string(c) + " numbers, expected " + std::to_string(cols));
        for (size_t k = 0; k < c; ++k) m(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = row.at(k).number();
    }
    return m;
}

}  // namespace

GeneralisedPlant parse_plant(const nlohmann::json& j, const std::string& path) {
    const Field f(j, path);
    if (!f.is_object()) f.fail("must be an object with A, B, C, D and partition");
    std::vector<std::string> allowed{"A", "B", "C", "D", "partition", "name", "description", "source", "comment", "units"};
    for (auto it = j.begin(); it != j.end(); ++it)
        if (!it.key().empty() && it.key()[0] == '_') allowed.push_back(it.key());
    f.only(allowed);
    const Field part = f["partition"];
    part.only({"w", "u", "z", "y"});
    GeneralisedPlant p;
    p.n_w = part["w"].integer(1, kMaxPlantSignals);
    p.n_u = part["u"].integer(1, kMaxPlantSignals);
    p.n_z = part["z"].integer(1, kMaxPlantSignals);
    p.n_y = part["y"].integer(1, kMaxPlantSignals);
    const Field a = f["A"];
    const auto n = static_cast<Eigen::Index>(a.size(static_cast<size_t>(kMaxPlantStates)));
    if (n < 1) a.fail("at least one state");
    p.sys.A = read_matrix(a, n, n);
    p.sys.B = read_matrix(f["B"], n, p.n_w + p.n_u);
    p.sys.C = read_matrix(f["C"], p.n_z + p.n_y, n);
    p.sys.D = read_matrix(f["D"], p.n_z + p.n_y, p.n_w + p.n_u);
    return p;
}

GeneralisedPlant load_plant_file(const std::string& filename) {
    if (!std::ifstream(filename)) throw std::invalid_argument(filename + ": cannot open the plant file");
    nlohmann::json j;
    try {
        j = hostjson::read_file(filename, {std::size_t{8} << 20, 8});
    } catch (const hostjson::JsonError& e) {
        const std::string m = e.what();
        if (m.rfind(filename, 0) == 0) throw;
        throw std::invalid_argument(filename + ": plant." + m);
    }
    try {
        return parse_plant(j, "plant");
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(filename + ": " + e.what());
    }
}

nlohmann::json matrix_json(const Eigen::MatrixXd& m) {
    nlohmann::json rows = nlohmann::json::array();
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
        nlohmann::json r = nlohmann::json::array();
        for (Eigen::Index k = 0; k < m.cols(); ++k) r.push_back(m(i, k));
        rows.push_back(r);
    }
    return rows;
}

nlohmann::json state_space_json(const StateSpace& g) {
    return {{"A", matrix_json(g.A)}, {"B", matrix_json(g.B)}, {"C", matrix_json(g.C)}, {"D", matrix_json(g.D)}};
}

}  // namespace piezoloop::design
