// The virtual probe: the sample's height where the stage truly is, each
// tick: at the coupled stage's positions (CoupledStage::position_um, what
// the sensors would read before their own dynamics and noise), not at the
// sensors' readings, so that the images show what sensor errors do.
#pragma once

#include "piezoloop/axes/coupled_stage.hpp"
#include "scan/sample_surface.hpp"

namespace piezoloop::scan {

class VirtualProbe {
public:
    explicit VirtualProbe(const SampleSurface& surface) : surface_(surface) {}
    // Axis 0 is x, axis 1 y.
    double read_nm(const CoupledStage& stage) const {
        return surface_.height_at_nm(stage.position_um(0), stage.position_um(1));
    }
    const SampleSurface& surface() const { return surface_; }

private:
    SampleSurface surface_;
};

}  // namespace piezoloop::scan
