#include "circtest/analysis/remedy.hpp"

namespace circtest {

std::string_view library_remedy_words(Remedy remedy) noexcept {
  switch (remedy) {
    case Remedy::give_radius:
      return "the nominal radius setting";
    case Remedy::give_centre:
      return "the set-up centre setting";
    case Remedy::f_about_nominal:
      return "F about the nominal centre";
    case Remedy::units_inch:
      return "the position unit inch";
    case Remedy::units_mm:
      return "the position unit mm";
    case Remedy::give_plane:
      return "the plane setting";
    case Remedy::evaluate_anyway:
      return "the warn-only setting";
    case Remedy::radius_tolerance:
      return "the radius tolerance setting";
    case Remedy::give_machine:
      return "the machine name argument";
  }
  return "a setting";
}

}  // namespace circtest
