#include "sim/camera/depth_xml.hpp"

#include <fmt/format.h>

namespace vgr::sim {
namespace {

std::string intReg(const std::string& name, std::uint32_t address, const char* access) {
  return fmt::format(
      "\t<IntReg Name=\"{0}Reg\" NameSpace=\"Custom\">\n\t\t<Address>0x{1:x}</Address>\n\t\t<Length>4</Length>\n"
      "\t\t<AccessMode>{2}</AccessMode>\n\t\t<pPort>Device</pPort>\n\t\t<Sign>Unsigned</Sign>\n"
      "\t\t<Endianess>BigEndian</Endianess>\n\t</IntReg>\n",
      name, address, access);
}

std::string enumeration(const std::string& name, std::initializer_list<std::pair<const char*, int>> entries,
                        std::uint32_t address, const char* access) {
  std::string s = fmt::format("\t<Enumeration Name=\"{}\" NameSpace=\"Standard\">\n", name);
  for (const auto& [entry, value] : entries)
    s += fmt::format("\t\t<EnumEntry Name=\"{}\" NameSpace=\"Standard\">\n\t\t\t<Value>{}</Value>\n\t\t</EnumEntry>\n", entry,
                     value);
  s += fmt::format("\t\t<pValue>{}Reg</pValue>\n\t</Enumeration>\n", name);
  return s + intReg(name, address, access);
}

std::string floatFeature(const std::string& name, std::uint32_t address) {
  return fmt::format(
      "\t<Float Name=\"{0}\" NameSpace=\"Standard\">\n\t\t<pValue>{0}Reg</pValue>\n\t</Float>\n"
      "\t<FloatReg Name=\"{0}Reg\" NameSpace=\"Custom\">\n\t\t<Address>0x{1:x}</Address>\n\t\t<Length>8</Length>\n"
      "\t\t<AccessMode>RO</AccessMode>\n\t\t<pPort>Device</pPort>\n\t\t<Endianess>BigEndian</Endianess>\n\t</FloatReg>\n",
      name, address);
}

bool replaceOnce(std::string& text, const std::string& anchor, const std::string& with) {
  const auto at = text.find(anchor);
  if (at == std::string::npos) return false;
  text.replace(at, anchor.size(), with);
  return true;
}

}  // namespace

Result<std::string> depthCameraXml(const std::string& stockXml) {
  std::string xml = stockXml;
  const std::string pixelAnchor = "<pValue>PixelFormatRegister</pValue>";
  if (!replaceOnce(xml, pixelAnchor,
                   fmt::format("<EnumEntry Name=\"Coord3D_C16\" NameSpace=\"Standard\">\n\t\t\t<Value>{}</Value>\n\t\t</EnumEntry>\n\t\t",
                               kPixelFormatCoord3dC16) +
                       pixelAnchor))
    return fail(Status::Internal, "depth camera XML: the stock XML has no '" + pixelAnchor + "'");
  const std::string rootAnchor = "<pFeature>ImageFormatControl</pFeature>";
  if (!replaceOnce(xml, rootAnchor, rootAnchor + "\n\t\t<pFeature>Scan3dControl</pFeature>"))
    return fail(Status::Internal, "depth camera XML: the stock XML has no '" + rootAnchor + "'");
  std::string scan3d = "\t<!-- Scan3dControl (SFNC), vgr depth emulator -->\n\n\t<Category Name=\"Scan3dControl\" NameSpace=\"Standard\">\n";
  for (const char* f : {"Scan3dDistanceUnit", "Scan3dCoordinateSelector", "Scan3dCoordinateSystem", "Scan3dOutputMode",
                        "Scan3dCoordinateScale", "Scan3dCoordinateOffset", "Scan3dInvalidDataFlag", "Scan3dInvalidDataValue",
                        "Scan3dFocalLength", "Scan3dPrincipalPointU", "Scan3dPrincipalPointV"})
    scan3d += fmt::format("\t\t<pFeature>{}</pFeature>\n", f);
  scan3d += "\t</Category>\n\n";
  scan3d += enumeration("Scan3dDistanceUnit", {{"Millimeter", 0}, {"Inch", 1}, {"Pixel", 2}}, kScan3dDistanceUnit, "RO");
  scan3d += enumeration("Scan3dCoordinateSelector", {{"CoordinateA", 0}, {"CoordinateB", 1}, {"CoordinateC", 2}},
                        kScan3dCoordinateSelector, "RW");
  scan3d += enumeration("Scan3dCoordinateSystem", {{"Cartesian", 0}}, kScan3dCoordinateSystem, "RO");
  scan3d += enumeration("Scan3dOutputMode", {{"RectifiedC", 0}, {"UncalibratedC", 1}}, kScan3dOutputMode, "RO");
  scan3d += "\t<Boolean Name=\"Scan3dInvalidDataFlag\" NameSpace=\"Standard\">\n\t\t<pValue>Scan3dInvalidDataFlagReg</pValue>\n"
            "\t\t<OnValue>1</OnValue>\n\t\t<OffValue>0</OffValue>\n\t</Boolean>\n";
  scan3d += intReg("Scan3dInvalidDataFlag", kScan3dInvalidDataFlag, "RO");
  scan3d += floatFeature("Scan3dCoordinateScale", kScan3dCoordinateScale);
  scan3d += floatFeature("Scan3dCoordinateOffset", kScan3dCoordinateOffset);
  scan3d += floatFeature("Scan3dInvalidDataValue", kScan3dInvalidDataValue);
  scan3d += floatFeature("Scan3dFocalLength", kScan3dFocalLength);
  scan3d += floatFeature("Scan3dPrincipalPointU", kScan3dPrincipalPointU);
  scan3d += floatFeature("Scan3dPrincipalPointV", kScan3dPrincipalPointV);
  const std::string endAnchor = "</RegisterDescription>";
  if (!replaceOnce(xml, endAnchor, scan3d + "\n" + endAnchor))
    return fail(Status::Internal, "depth camera XML: the stock XML has no '" + endAnchor + "'");
  return xml;
}

}  // namespace vgr::sim
