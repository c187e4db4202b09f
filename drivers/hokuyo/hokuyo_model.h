#pragma once
/// @file
/// Hokuyo sensor models as their PP reply describes them (docs/protocols.md §1.5), the
/// step-to-angle convention, and the meaning of range values below DMIN (error codes), mapped
/// to the planar_scan_t contract per docs/protocols.md §1.6: a "no object" code or a range at or
/// beyond DMAX is "no return" (0); interference and other codes carry no information (NaN).

#include <optional>
#include <string>

namespace kestrel {

/// The parameters of a PP reply (and what the emulator serves).
struct HokuyoModel {
  std::string name;              ///< short name: "URG-04LX", "UTM-30LX"
  std::string modl;              ///< PP MODL text
  std::string product;           ///< VV PROD text
  int dmin_mm{0};                ///< DMIN: shortest valid range, mm; smaller values are error codes
  int dmax_mm{0};                ///< DMAX: longest valid range, mm
  int ares{0};                   ///< ARES: steps per full turn
  int amin{0};                   ///< AMIN: first measurable step
  int amax{0};                   ///< AMAX: last measurable step
  int afrt{0};                   ///< AFRT: the step pointing forward (+x of the sensor frame)
  int scan_rpm{0};               ///< SCAN: mirror speed, rev/min (one scan per revolution)
  bool starts_in_scip11{false};  ///< powers up speaking SCIP 1.1 (URG-04LX)
  bool has_intensity{false};     ///< answers ME/GE

  /// Scan period, s (60 / SCAN).
  [[nodiscard]] double scan_period_s() const { return 60.0 / scan_rpm; }
  /// Angle of step s about +z of the sensor frame, rad: (s - AFRT) * 2 pi / ARES.
  [[nodiscard]] double StepAngleRad(int step) const;
};

/// URG-04LX: DMIN 20, DMAX 5600, ARES 1024, AMIN 44, AMAX 725, AFRT 384, SCAN 600; SCIP 1.1 at
/// power-up.
[[nodiscard]] const HokuyoModel& Urg04lxModel();
/// UTM-30LX: DMIN 23, DMAX 60000, ARES 1440, AMIN 0, AMAX 1080, AFRT 540, SCAN 2400.
[[nodiscard]] const HokuyoModel& Utm30lxModel();
/// "URG-04LX" or "UTM-30LX" (case-insensitive); nullopt for anything else.
[[nodiscard]] std::optional<HokuyoModel> FindHokuyoModel(const std::string& name);

/// What a range value means.
enum class RangeClass {
  kReturn,    ///< DMIN <= value < DMAX: a return at value mm
  kNoReturn,  ///< nothing within range: a "no object" code, or value >= DMAX
  kInvalid,   ///< no information: interference, too near, other codes
};

/// Classifies a raw range value for a sensor family ("URG-04LX": code 0 = no object (object
/// possibly at 22 m), 1-19 other; "UTM-30LX": code 1 = no object in range, 2 too near, 3
/// interference, 4 out of range at the near end, 5 other). Unknown families: every code invalid.
[[nodiscard]] RangeClass ClassifyRange(const std::string& model_name, int dmin_mm, int dmax_mm,
                                       unsigned value_mm);
/// The raw code the sensor sends for "no object" (URG-04LX 0, UTM-30LX 1).
[[nodiscard]] unsigned NoObjectCode(const std::string& model_name);
/// A raw code the sensor sends for interference (URG-04LX 7, UTM-30LX 3).
[[nodiscard]] unsigned InterferenceCode(const std::string& model_name);

}  // namespace kestrel
