// The field log (issue 29): what a run saw and estimated, as an MCAP file (io/mcap_writer.h) with
// Foxglove's ROS 2 message types (io/foxglove_msgs.h), so that the run can be replayed and mapped
// again later (`mcap:FILE`, io/mcap_source.h) and opened in Foxglove or ROS 2's tools.
//
// Topics (message time = the frame's timestamp):
//   /camera/calibration      CameraCalibration, before the first frame
//   /camera/depth            depth in millimetres, lossless: CompressedImage "png" (16-bit gray), or
//                            RawImage "16UC1" (log.depth raw: no encoding work)
//   /camera/color            colour: CompressedImage "jpeg" or "png", or RawImage "rgb8"; every
//                            log.color_every-th frame; none with log.color none
//   /camera/reference_pose   PoseInFrame: the source's reference pose, when it has one (a dataset)
//   /edgefusion/pose         PoseInFrame in "world": the mapper's estimate, each mapped frame
//   /tf                      FrameTransform world -> camera: the same, for Foxglove's 3D panel
//   /edgefusion/labels       CompressedImage "png" of class ids, when the CNN labelled a frame
//   /edgefusion/map          PointCloud of the map (x y z, red green blue alpha, class) at each
//                            checkpoint (log.map), streamed from the pool's columns
//   /log                     Log: start, stop, errors, lost tracking
//
// Depth goes in as uint16 millimetres, round(metres * 1000), 0 = invalid (the .klg writer's rule),
// so millimetre sensors (Kinect, 7-Scenes) replay bit for bit.
//
// Faults: the first write that fails (a full disk) is kept and returned by every later call; the
// file then ends at its last whole chunk, which readers read (io/mcap_reader.h).
//
// Threads: any thread may log; each thread passes its own Encoder (the image encoding runs outside
// the lock; only appending to the open chunk, and writing a chunk out when it is due, holds it).
// Memory: open() sizes the chunk buffer; each Encoder is sized at make_encoder() for the frame size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/frame.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/options.h"
#include "core/result.h"
#include "io/foxglove_msgs.h"
#include "io/mcap_writer.h"
#include "io/ply_writer.h"
#include "io/png_encoder.h"

namespace ef {

struct McapLogOptions {
  std::string file;            // the log; relative: in the run folder; empty = no log (`run`)
  std::string depth = "png";   // png (lossless, zlib level png_level) | raw (16UC1, no encoding)
  std::string color = "jpeg";  // jpeg | png | raw (rgb8) | none
  int64_t color_every = 1;     // colour of every n-th frame (1 = all)
  int64_t jpeg_quality = 90;   // 1..100
  int64_t png_level = 1;       // zlib level of the PNGs, 1 (fastest) .. 9
  double chunk_seconds = 1;    // a chunk spans at most this much log time: what a cut may lose, s
  int64_t chunk_mb = 8;        // and at most this many MB (10^6 bytes)
  bool sync = true;            // fdatasync after each chunk (a power cut loses at most the open chunk)
  bool map = true;             // the map as a PointCloud at each checkpoint

  static const opt::Table<McapLogOptions>& table();
  Status validate() const;
};

class McapFrameLog {
 public:
  // One thread's encoding state: a PNG encoder and its buffers, sized for the frame size.
  struct Encoder {
    std::unique_ptr<PngEncoder> png;
    std::vector<uint16_t> millimetres;
    std::string image, message;
  };

  McapFrameLog() = default;
  ~McapFrameLog();  // closes (errors ignored: call close())
  McapFrameLog(const McapFrameLog&) = delete;
  McapFrameLog& operator=(const McapFrameLog&) = delete;

  // Creates the file (errors: the file's), its schemas and channels; frames of width x height.
  Status open(const std::string& path, const McapLogOptions& options, int width, int height,
              const Intrinsics& intrinsics);
  // An encoder for one thread (allocates): for images up to width x height (0: the log's frame
  // size), or without images (poses and text only).
  std::unique_ptr<Encoder> make_encoder(bool with_images = true, int width = 0, int height = 0) const;
  // Bytes of one encoder for images up to width x height.
  static std::size_t encoder_bytes_for(int width, int height);
  // Bytes open() allocates (the chunk buffer) and a run's encoders: the front's for the frames of
  // width x height, and the mapping thread's, for label images of label_width x label_height (0 x 0:
  // no labels, poses and text only). The memory plan's line.
  static std::size_t bytes_for(const McapLogOptions& options, int width, int height, int label_width = 0,
                               int label_height = 0);

  // The source's frame: depth, colour (when due and present), reference pose (when it has one).
  Status log_frame(const Frame& frame, Encoder& enc);
  // The mapper's pose of the frame at `timestamp`, as PoseInFrame and FrameTransform.
  Status log_pose(double timestamp, const SE3& T_wc, Encoder& enc);
  // A class-id image the CNN produced for the frame at `timestamp` (an encoder with images of its size).
  Status log_labels(double timestamp, ImageView<const uint8_t> labels, Encoder& enc);
  Status log_text(double timestamp, foxglove::LogLevel level, std::string_view text, Encoder& enc);
  // The map as a PointCloud in "world", streamed from its columns in pieces (no copy of the map:
  // a chunk of its own; the other threads' messages wait for it). Class ids when the view has them.
  Status log_map(double timestamp, const SurfelCloudView& cloud);
  // Closes the open chunk now (everything so far is readable after a cut).
  Status flush();
  // Writes the summary and closes the file. Returns the first error the log met, if any.
  Status close();

  bool is_open() const { return open_; }
  const std::string& path() const { return path_; }
  uint64_t frames() const;
  uint64_t messages() const;

 private:
  Status put(uint16_t channel, uint64_t stamp_ns, const std::string& message);
  McapLogOptions options_;
  std::string path_;
  int width_ = 0, height_ = 0;
  Intrinsics intrinsics_;
  bool open_ = false;
  mutable std::mutex mutex_;  // guards everything below
  McapWriter writer_;
  std::optional<Error> failed_;
  bool calibration_written_ = false;
  uint64_t frames_ = 0;
  static constexpr std::size_t kMapPiecePoints = 4096;
  std::vector<uint8_t> map_piece_;  // log_map's points, a piece at a time (20 bytes a point at most)
  std::string map_head_;
  enum Channel { kCalibration, kDepth, kColor, kReferencePose, kPose, kTf, kLabels, kLog, kMap, kChannels };
  uint16_t channel_[kChannels] = {};
};

// Depth in metres to uint16 millimetres (the .klg writer's rule); dst holds width*height values.
void depth_to_millimetres(const Image<float>& depth, uint16_t* dst);

}  // namespace ef
