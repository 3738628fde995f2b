// Decodes every fieldline type that encode_all wrote, with the generated Java classes (what
// lcm-spy uses), re-encodes it and compares the bytes; also checks a few field values.
import java.io.ByteArrayOutputStream;
import java.io.DataOutputStream;
import java.lang.reflect.Field;
import java.nio.file.Files;
import java.nio.file.Paths;
import java.util.Arrays;

public class DecodeCheck {
  static final String[] TYPES = {
    "header_t", "image_t", "line_contours_t", "ball_observation_t", "obstacle_observations_t",
    "field_features_t", "odometry_t", "motion_command_t", "robot_state_t", "ball_state_t",
    "team_state_t", "service_status_t", "world_state_t", "recording_info_t"};

  public static void main(String[] args) throws Exception {
    String dir = args[0];
    int failures = 0;
    for (int k = 0; k < TYPES.length; ++k) {
      String name = TYPES[k];
      byte[] bytes = Files.readAllBytes(Paths.get(dir, name + ".bin"));
      Class<?> cls = Class.forName("fieldline." + name);
      Object msg = cls.getConstructor(byte[].class).newInstance((Object) bytes);
      ByteArrayOutputStream bos = new ByteArrayOutputStream();
      cls.getMethod("encode", java.io.DataOutput.class).invoke(msg, new DataOutputStream(bos));
      boolean same = Arrays.equals(bytes, bos.toByteArray());
      // Header values written by encode_all: utime = 1.7e15 + k, seq = 40 + k.
      Object header = name.equals("header_t") ? msg : cls.getField("header").get(msg);
      long utime = header.getClass().getField("utime").getLong(header);
      long seq = header.getClass().getField("seq").getLong(header);
      boolean headerOk = utime == 1700000000000000L + k + 1 && seq == 40 + k + 1;
      System.out.println(name + ": " + bytes.length + " bytes, re-encoded "
          + (same ? "identical" : "DIFFERENT") + ", header " + (headerOk ? "ok" : "WRONG"));
      if (!same || !headerOk) ++failures;
    }
    fieldline.service_status_t s = new fieldline.service_status_t(
        Files.readAllBytes(Paths.get(dir, "service_status_t.bin")));
    if (!s.process.equals("region_tracking") || s.num_channels != 2
        || !s.channel[1].equals("VISION_LINES") || s.rate_hz[0] != 30.0f) {
      System.out.println("service_status_t: field values WRONG");
      ++failures;
    }
    fieldline.odometry_t o = new fieldline.odometry_t(
        Files.readAllBytes(Paths.get(dir, "odometry_t.bin")));
    if (o.wheel_count != 4 || o.ticks.length != 4 || o.ticks[2] != 2147483000 || o.ticks[3] != -7
        || o.wheel_current[3] != 2.0f || o.dx != 0.01 || o.status != 12) {
      System.out.println("odometry_t: field values WRONG");
      ++failures;
    }
    System.out.println(failures == 0 ? "all types decode in Java" : failures + " FAILURES");
    System.exit(failures == 0 ? 0 : 1);
  }
}
