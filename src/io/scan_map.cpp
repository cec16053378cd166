#include "flexcloud/io/scan_map.h"

#include <algorithm>
#include <cstring>

#include "flexcloud/io/cloud_layout.h"
#include "flexcloud/types.h"

namespace flexcloud {
namespace {

bool sameFields(const std::vector<pcl::PCLPointField>& a,
                const std::vector<pcl::PCLPointField>& b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](const auto& x, const auto& y) {
           return x.name == y.name && x.offset == y.offset && x.datatype == y.datatype &&
                  x.count == y.count;
         });
}

}  // namespace

void ScanMap::add(const pcl::PCLPointCloud2& scan, double stamp, const std::string& name) {
  const std::size_t n = static_cast<std::size_t>(scan.width) * scan.height;
  xyzLayout(scan, name);  // x, y, z there, and the data as long as the points
  for (const auto& f : scan.fields) {
    if (f.name == kScanTimeField) throw Error(name + ": a scan holds a field scan_time already");
  }
  if (scans_ == 0) {
    fields_ = scan.fields;
    scan_step_ = scan.point_step;
    step_ = scan.point_step + 8;
  } else if (scan.point_step != scan_step_ || !sameFields(scan.fields, fields_)) {
    throw Error(name + ": a scan's fields differ from those of the first scan");
  }
  const std::size_t at = data_.size();
  data_.resize(at + n * step_);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint8_t* row = data_.data() + at + i * step_;
    std::memcpy(row, scan.data.data() + i * scan_step_, scan_step_);
    std::memcpy(row + scan_step_, &stamp, sizeof(double));
  }
  ++scans_;
}

pcl::PCLPointCloud2 ScanMap::cloud() const {
  pcl::PCLPointCloud2 c;
  c.fields = fields_;
  c.fields.push_back(pointField(kScanTimeField, scan_step_, pcl::PCLPointField::FLOAT64));
  c.point_step = step_;
  c.height = 1;
  c.width = static_cast<std::uint32_t>(points());
  c.row_step = c.point_step * c.width;
  c.is_dense = 0;
  c.data = data_;
  return c;
}

void ScanMap::clear() {
  fields_.clear();
  scan_step_ = step_ = 0;
  data_.clear();
  data_.shrink_to_fit();
  scans_ = 0;
}

}  // namespace flexcloud
