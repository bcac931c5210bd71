#pragma once
// A scene's contact model together with the Moreau–Jean settings of the same scene, read as a
// contact process reads them (BuildContactModel, ReadMoreauJeanSettings): the tests build an
// integrator from one text with `MoreauJean mj(scene, scene.settings, t0)`.
#include <string>
#include <vector>

#include "interface/scenario/scenario_file.h"
#include "nonsmooth_solver/integrator/moreau_jean_settings.h"
#include "nonsmooth_solver/model/contact_model.h"

namespace cosim::nonsmooth {

struct ContactScene : ContactModel {
  MoreauJeanSettings settings;
};

inline ContactScene LoadContactScene(const std::string& text, const std::string& name,
                                     const std::vector<std::string>& sets = {}) {
  const interface::ScenarioFile file = interface::ScenarioFile::Parse(text, name, sets);
  ContactScene scene;
  static_cast<ContactModel&>(scene) = BuildContactModel(file);
  scene.settings = ReadMoreauJeanSettings(file);
  return scene;
}

}  // namespace cosim::nonsmooth
