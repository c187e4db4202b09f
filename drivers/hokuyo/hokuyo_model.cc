#include "drivers/hokuyo/hokuyo_model.h"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace kestrel {

double HokuyoModel::StepAngleRad(int step) const {
  return static_cast<double>(step - afrt) * 2.0 * M_PI / static_cast<double>(ares);
}

const HokuyoModel& Urg04lxModel() {
  static const HokuyoModel model = [] {
    HokuyoModel m;
    m.name = "URG-04LX";
    m.modl = "URG-04LX(Hokuyo Automatic Co.,Ltd.)";
    m.product = "SOKUIKI Sensor URG-04LX";
    m.dmin_mm = 20;
    m.dmax_mm = 5600;
    m.ares = 1024;
    m.amin = 44;
    m.amax = 725;
    m.afrt = 384;
    m.scan_rpm = 600;
    m.starts_in_scip11 = true;
    m.has_intensity = false;
    return m;
  }();
  return model;
}

const HokuyoModel& Utm30lxModel() {
  static const HokuyoModel model = [] {
    HokuyoModel m;
    m.name = "UTM-30LX";
    m.modl = "UTM-30LX";
    m.product = "SOKUIKI Sensor TOP-URG UTM-30LX";
    m.dmin_mm = 23;
    m.dmax_mm = 60000;
    m.ares = 1440;
    m.amin = 0;
    m.amax = 1080;
    m.afrt = 540;
    m.scan_rpm = 2400;
    m.starts_in_scip11 = false;
    m.has_intensity = true;
    return m;
  }();
  return model;
}

std::optional<HokuyoModel> FindHokuyoModel(const std::string& name) {
  std::string upper = name;
  std::transform(upper.begin(), upper.end(), upper.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  if (upper == "URG-04LX") return Urg04lxModel();
  if (upper == "UTM-30LX") return Utm30lxModel();
  return std::nullopt;
}

RangeClass ClassifyRange(const std::string& model_name, int dmin_mm, int dmax_mm,
                         unsigned value_mm) {
  if (value_mm >= static_cast<unsigned>(dmax_mm)) return RangeClass::kNoReturn;
  if (value_mm >= static_cast<unsigned>(dmin_mm)) return RangeClass::kReturn;
  // Error codes (docs/protocols.md §1.6): only "no object" says something about the ray.
  if (model_name.find("URG-04LX") != std::string::npos && value_mm == 0) {
    return RangeClass::kNoReturn;
  }
  if (model_name.find("UTM-30LX") != std::string::npos && value_mm == 1) {
    return RangeClass::kNoReturn;
  }
  return RangeClass::kInvalid;
}

unsigned NoObjectCode(const std::string& model_name) {
  return model_name.find("UTM-30LX") != std::string::npos ? 1u : 0u;
}

unsigned InterferenceCode(const std::string& model_name) {
  return model_name.find("UTM-30LX") != std::string::npos ? 3u : 7u;
}

}  // namespace kestrel
