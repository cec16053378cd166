#pragma once
// PCD files in every encoding, read strictly by our own readers (PCL supplies the cloud type and
// the LZF codec), with errors that name the file and the problem.

#include <pcl/PCLPointCloud2.h>

#include <string>

namespace flexcloud {

/// Reads a PCD file (ascii, binary or binary_compressed) with all its fields, organized or not.
/// The header is checked first (pcd_header.h), then the body by the reader of its encoding.
/// Throws Error "FILE: ..." for a missing file, a file that is not PCD, a bad header, a value
/// that is not a number of its field's type, or a body shorter than the header promises.
pcl::PCLPointCloud2 readPcd(const std::string& path);

/// Writes a binary PCD under a temporary name and renames it onto `path` when complete.
void writePcdBinary(const std::string& path, const pcl::PCLPointCloud2& cloud);
/// The same from a raw point buffer (e.g. a sensor_msgs/PointCloud2's data).
void writePcdBinary(const std::string& path, const std::vector<pcl::PCLPointField>& fields,
                    std::size_t point_step, std::uint32_t width, std::uint32_t height,
                    const std::uint8_t* data, std::size_t bytes);

}  // namespace flexcloud
