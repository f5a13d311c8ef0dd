#include "sim/in_process_can_rig.hpp"

namespace dualv::sim {

InProcessCanRig::InProcessCanRig(const model::Model& model, const PlantConfig& plant_config,
                                 const DriveEmulatorConfig& emulator, std::size_t queue_capacity)
    : hub_(3, queue_capacity) {
  emulator.validate(model.n);
  master_ = &hub_.endpoint(kMasterEndpoint);
  monitor_ = &hub_.endpoint(kMonitorEndpoint);
  plant_ = std::make_unique<Plant>(model, emulator_plant_config(plant_config, emulator));
  emulator_ = std::make_unique<DriveEmulator>(hub_.endpoint(kEmulatorEndpoint), *plant_, emulator);
}

InProcessCanRig::InProcessCanRig(const model::Model& model, const PlantConfig& plant_config,
                                 const fw::CanConfig& can, std::size_t queue_capacity)
    : InProcessCanRig(model, plant_config, emulator_config_from(can), queue_capacity) {}

}  // namespace dualv::sim
