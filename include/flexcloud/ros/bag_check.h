#pragma once
// Checks of a bag's bytes before rosbag reads them. rosbag trusts the lengths it finds: a
// corrupt record length makes it reserve gigabytes, and a corrupt vector length in a message
// makes the deserializer resize to it before it checks the message's size.

#include <cstdint>
#include <string>

namespace flexcloud {

/// Walks every record of a rosbag v2.0 file (and the records inside uncompressed chunks):
/// lengths within the file, header fields within the header, chunk sizes and index positions
/// plausible, an index present. Throws Error "BAG: ..." naming the first problem.
void checkBagStructure(const std::string& path);

/// For a serialized nav_msgs/Path or sensor_msgs/PointCloud2: whether the vector lengths in it
/// fit the message's own size (the only variable-length vectors flexcloud reads).
bool pathLengthsFit(const std::uint8_t* data, std::size_t size);
bool cloudLengthsFit(const std::uint8_t* data, std::size_t size);

}  // namespace flexcloud
