// Runs lcm-spy (lcm.spy.Spy, the class scripts/ndsid-lcm-spy starts) in this JVM on a display
// (xvfb-run), publishes one message of every ndsid type on its channel 20 times, then reads the
// spy's channel table: each channel must show our type's name, the messages, none undecodable.
// Catches: types on the class path but not matched by fingerprint (a stale jar: "Undecodable"),
// or not found at all (no type name in the table). Exit 0 ok, 1 not decoded, 2 nothing received.
//   java -cp ndsid_lcmtypes.jar:lcm.jar:jchart2d.jar SpyProbe.java URL
import java.awt.Component;
import java.awt.Container;
import java.awt.Frame;
import java.lang.reflect.Array;
import java.lang.reflect.Field;
import java.lang.reflect.Modifier;
import java.util.LinkedHashMap;
import java.util.Map;
import javax.swing.JTable;
import javax.swing.SwingUtilities;

public class SpyProbe {
  static JTable findTable(Container c) {
    for (Component k : c.getComponents()) {
      if (k instanceof JTable) return (JTable) k;
      if (k instanceof Container) {
        JTable t = findTable((Container) k);
        if (t != null) return t;
      }
    }
    return null;
  }

  // A message with every string "" and every array empty (counts stay 0), so encode() works.
  static lcm.lcm.LCMEncodable emptyMessage(String type) throws Exception {
    Object m = Class.forName(type).getDeclaredConstructor().newInstance();
    for (Field f : m.getClass().getFields()) {
      if (Modifier.isStatic(f.getModifiers())) continue;
      if (f.getType() == String.class) f.set(m, "");
      else if (f.getType().isArray()) f.set(m, Array.newInstance(f.getType().getComponentType(), 0));
    }
    return (lcm.lcm.LCMEncodable) m;
  }

  public static void main(String[] args) throws Exception {
    String url = args[0];
    Map<String, String> channels = new LinkedHashMap<>();
    channels.put("NDSID_ESTIMATE", "ndsid.estimate_t");
    channels.put("NDSID_STATUS", "ndsid.status_t");
    channels.put("NDSID_MONITOR", "ndsid.monitor_t");
    lcm.spy.Spy.main(new String[] {"--lcm-url=" + url});
    Thread.sleep(2000);
    lcm.lcm.LCM lc = new lcm.lcm.LCM(url);
    final int n = 20;
    for (int i = 0; i < n; ++i) {
      for (Map.Entry<String, String> e : channels.entrySet()) lc.publish(e.getKey(), emptyMessage(e.getValue()));
      Thread.sleep(50);
    }
    Thread.sleep(2000);
    final StringBuilder table = new StringBuilder();
    SwingUtilities.invokeAndWait(() -> {
      for (Frame f : Frame.getFrames()) {
        JTable t = findTable(f);
        if (t == null) continue;
        for (int r = 0; r < t.getRowCount(); ++r) {
          for (int c = 0; c < t.getColumnCount(); ++c) {
            table.append(t.getColumnName(c)).append('=').append(t.getValueAt(r, c)).append(c + 1 < t.getColumnCount() ? "\t" : "\n");
          }
        }
      }
    });
    System.out.print(table);
    if (table.length() == 0) {
      System.out.println("SpyProbe: the spy received nothing (no multicast loopback? see docs/monitoring.md)");
      System.exit(2);
    }
    int ok = 0;
    for (Map.Entry<String, String> e : channels.entrySet()) {
      String shortType = e.getValue().substring(e.getValue().indexOf('.') + 1);
      for (String row : table.toString().split("\n")) {
        if (row.startsWith("Channel=" + e.getKey() + "\t") && row.contains("Type=" + shortType + "\t")
            && row.contains("Num Msgs=" + n + "\t") && row.endsWith("Undecodable=0")) {
          ++ok;
        }
      }
    }
    System.out.println("SpyProbe: " + ok + " of " + channels.size() + " channels decoded (" + n + " messages each, none undecodable)");
    System.exit(ok == channels.size() ? 0 : 1);
  }
}
