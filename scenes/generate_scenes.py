#!/usr/bin/env python3
"""Writes the MJCF scenes of fleetslam (office, apartment, warehouse) from a compact layout description.

    python3 scenes/generate_scenes.py            # rewrites scenes/*/<scene>.xml beside this script

The XML files are committed; edit this script and rerun it rather than editing them by hand. The layout
is deterministic (Python's random.Random with fixed seeds). Conventions (see scenes/README.md):
z up, metres, floor at z=0, static geometry only (worldbody geoms, no joints), lights without shadows,
no <visual>/<compiler>/<option> (the World's wrapper model owns those), textures as type="2d" PNGs from
../textures/ mapped once across the +z face of thin boxes whose local z is the face normal.
"""

import math
import os
import random

HERE = os.path.dirname(os.path.abspath(__file__))


def f(v):
    s = "%.4f" % v
    s = s.rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def fv(*vals):
    return " ".join(f(v) for v in vals)


class Scene:
    def __init__(self, name, comment):
        self.name = name
        self.comment = comment
        self.textures = []   # (name, file)
        self.materials = []  # xml strings
        self.mat_names = set()
        self.geoms = []      # xml strings (with group comments)
        self.lights = []
        self.counter = {}

    # -- assets ---------------------------------------------------------------------------------------
    def texture(self, tex):
        if tex not in [t for t, _ in self.textures]:
            self.textures.append((tex, "../textures/%s.png" % tex))
        return tex

    def material(self, name, tex=None, rgba=(1, 1, 1, 1), specular=0.05, shininess=0.1, texrepeat=None,
                 texuniform=False):
        if name in self.mat_names:
            return name
        self.mat_names.add(name)
        attrs = ['name="%s"' % name]
        if tex:
            self.texture(tex)
            attrs.append('texture="%s"' % tex)
        if texrepeat:
            attrs.append('texrepeat="%s"' % fv(*texrepeat))
        if texuniform:
            attrs.append('texuniform="true"')
        attrs.append('rgba="%s"' % fv(*rgba))
        attrs.append('specular="%s" shininess="%s"' % (f(specular), f(shininess)))
        self.materials.append("<material %s/>" % " ".join(attrs))
        return name

    def tex_material(self, tex, rgba=(1, 1, 1, 1), specular=0.05, suffix=""):
        """The material that shows texture `tex` once across a face."""
        return self.material("m_" + tex + suffix, tex, rgba=rgba, specular=specular)

    def colour(self, name, rgba, specular=0.1):
        return self.material("c_" + name, None, rgba=rgba, specular=specular)

    # -- geometry -------------------------------------------------------------------------------------
    def _name(self, prefix):
        n = self.counter.get(prefix, 0)
        self.counter[prefix] = n + 1
        return "%s_%d" % (prefix, n)

    def comment_line(self, text):
        self.geoms.append("<!-- %s -->" % text)

    def geom(self, prefix, gtype, pos, size, material=None, rgba=None, xyaxes=None, euler=None, collide=True,
             name=None, extra=""):
        attrs = ['name="%s"' % (name or self._name(prefix)), 'type="%s"' % gtype, 'pos="%s"' % fv(*pos),
                 'size="%s"' % fv(*size)]
        if xyaxes:
            attrs.append('xyaxes="%s"' % fv(*xyaxes))
        if euler:  # written as a quaternion so the scene does not depend on <compiler angle/eulerseq>
            attrs.append('quat="%s"' % fv(*euler_quat(*euler)))
        if material:
            attrs.append('material="%s"' % material)
        if rgba:
            attrs.append('rgba="%s"' % fv(*rgba))
        if not collide:
            attrs.append('contype="0" conaffinity="0"')
        if extra:
            attrs.append(extra)
        self.geoms.append("<geom %s/>" % " ".join(attrs))

    def box(self, prefix, lo, hi, material=None, rgba=None, collide=True, name=None):
        """Axis-aligned box from corner lo to corner hi."""
        c = [(a + b) / 2 for a, b in zip(lo, hi)]
        s = [abs(b - a) / 2 for a, b in zip(lo, hi)]
        self.geom(prefix, "box", c, s, material=material, rgba=rgba, collide=collide, name=name)

    def face(self, prefix, centre, normal, width, height, thickness, material, collide=True, up=(0, 0, 1),
             name=None):
        """A thin box whose +z face (centred at `centre`, facing `normal`) shows `material` once, upright.

        The texture's top edge is along `up`; width runs to the viewer's right. The box extends
        `thickness` behind the face."""
        n = normalise(normal)
        u = normalise(up)
        x = cross(u, n)  # viewer's right when looking at the face against its normal
        c = [centre[i] - n[i] * thickness / 2 for i in range(3)]
        self.geom(prefix, "box", c, (width / 2, height / 2, thickness / 2), material=material,
                  xyaxes=tuple(x) + tuple(u), collide=collide, name=name)

    def floor_patch(self, x0, y0, x1, y1, material, z=0.0, name=None):
        self.geom("floor", "plane", ((x0 + x1) / 2, (y0 + y1) / 2, z), ((x1 - x0) / 2, (y1 - y0) / 2, 0.1),
                  material=material, name=name)

    def ceiling(self, x0, y0, x1, y1, z, material):
        # A plane facing down; not a collider (a plane collides as a half-space).
        self.geom("ceiling", "plane", ((x0 + x1) / 2, (y0 + y1) / 2, z), ((x1 - x0) / 2, (y1 - y0) / 2, 0.1),
                  material=material, xyaxes=(1, 0, 0, 0, -1, 0), collide=False)

    def wall(self, x0, y0, x1, y1, normal, material, z0=0.0, z1=2.5, thickness=0.06, prefix="wall"):
        """A wall face along the segment (x0,y0)-(x1,y1) at floor level, facing `normal` (into the room)."""
        length = math.hypot(x1 - x0, y1 - y0)
        self.face(prefix, ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2), (normal[0], normal[1], 0), length,
                  z1 - z0, thickness, material)

    def light(self, pos, direction, diffuse, directional=True, ambient=(0, 0, 0), specular=(0.1, 0.1, 0.1)):
        self.lights.append('<light name="%s" directional="%s" castshadow="false" pos="%s" dir="%s" diffuse="%s" '
                           'ambient="%s" specular="%s"/>' % (self._name("light"), "true" if directional else "false",
                                                              fv(*pos), fv(*direction), fv(*diffuse), fv(*ambient),
                                                              fv(*specular)))

    # -- output ---------------------------------------------------------------------------------------
    def write(self, path):
        lines = ['<!-- Generated by scenes/generate_scenes.py: edit the script, not this file. -->',
                 '<mujoco model="%s">' % self.name]
        for c in self.comment.strip().splitlines():
            lines.append("  <!-- %s -->" % c.strip())
        lines.append("  <asset>")
        for name, file in self.textures:
            lines.append('    <texture name="%s" type="2d" file="%s"/>' % (name, file))
        for m in self.materials:
            lines.append("    " + m)
        lines.append("  </asset>")
        lines.append("  <worldbody>")
        for l in self.lights:
            lines.append("    " + l)
        for g in self.geoms:
            lines.append("    " + g)
        lines.append("  </worldbody>")
        lines.append("</mujoco>")
        with open(path, "w") as out:
            out.write("\n".join(lines) + "\n")
        ngeoms = sum(1 for g in self.geoms if g.startswith("<geom"))
        print("%s: %d geoms, %d textures, %d materials, %d lights" % (path, ngeoms, len(self.textures),
                                                                        len(self.materials), len(self.lights)))


def quat_mul(a, b):
    return (a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0])


def euler_quat(rx_deg, ry_deg, rz_deg):
    """MuJoCo's default euler convention (intrinsic x, y, z, degrees) as a quaternion (w x y z)."""
    q = (1.0, 0.0, 0.0, 0.0)
    for axis, deg in enumerate((rx_deg, ry_deg, rz_deg)):
        h = math.radians(deg) / 2
        e = [math.cos(h), 0.0, 0.0, 0.0]
        e[1 + axis] = math.sin(h)
        q = quat_mul(q, e)
    return q


def normalise(v):
    n = math.sqrt(sum(a * a for a in v))
    return [a / n for a in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


# ---------------------------------------------------------------------------------------------------
# Furniture, placed by the footprint's lower-left corner or centre; `facing` is the direction the front
# faces (+x, -x, +y, -y) given as a unit vector (fx, fy).

def rot(fx, fy, u, v):
    """Furniture-local (u, v) to world offsets for a front facing (fx, fy): v runs toward the front, u to
    the right of a viewer looking at the front (who looks along (-fx, -fy), so their right is (-fy, fx))."""
    rx, ry = -fy, fx
    return (u * rx + v * fx, u * ry + v * fy)


def lbox(s, prefix, origin, facing, u0, u1, v0, v1, z0, z1, material=None, rgba=None, collide=True):
    """A box in furniture-local coordinates: u across the front, v toward the front, z up."""
    fx, fy = facing
    a = rot(fx, fy, u0, v0)
    b = rot(fx, fy, u1, v1)
    lo = (origin[0] + min(a[0], b[0]), origin[1] + min(a[1], b[1]), z0)
    hi = (origin[0] + max(a[0], b[0]), origin[1] + max(a[1], b[1]), z1)
    s.box(prefix, lo, hi, material=material, rgba=rgba, collide=collide)


def fbox(s, prefix, origin, facing, u0, u1, v0, v1, z0, z1, material=None, rgba=None, collide=True):
    """Like lbox, but oriented so that the front face (toward `facing`) shows the material's texture."""
    fx, fy = facing
    a = rot(fx, fy, u0, v0)
    b = rot(fx, fy, u1, v1)
    c = (origin[0] + (a[0] + b[0]) / 2, origin[1] + (a[1] + b[1]) / 2, (z0 + z1) / 2)
    x = cross((0, 0, 1), (fx, fy, 0))
    s.geom(prefix, "box", c, ((u1 - u0) / 2, (z1 - z0) / 2, (v1 - v0) / 2), material=material, rgba=rgba,
           xyaxes=tuple(x) + (0, 0, 1), collide=collide)


def lface(s, prefix, origin, facing, u, v, z, width, height, thickness, material, collide=True):
    """A textured face in furniture-local coordinates facing the furniture's front."""
    fx, fy = facing
    o = rot(fx, fy, u, v)
    s.face(prefix, (origin[0] + o[0], origin[1] + o[1], z), (fx, fy, 0), width, height, thickness, material,
           collide=collide)


def bookshelf(s, origin, facing, width, height, depth, books_tex, frame_mat):
    """Open shelf: sides, top, plinth, back panel and a spine façade (texture rows match 4 shelves)."""
    w2 = width / 2
    t = 0.03
    lbox(s, "shelf", origin, facing, -w2, -w2 + t, 0, depth, 0, height, frame_mat)
    lbox(s, "shelf", origin, facing, w2 - t, w2, 0, depth, 0, height, frame_mat)
    lbox(s, "shelf", origin, facing, -w2, w2, 0, depth, height - t, height, frame_mat)
    lbox(s, "shelf", origin, facing, -w2 + t, w2 - t, 0, depth, 0, 0.08, frame_mat)
    lbox(s, "shelf", origin, facing, -w2 + t, w2 - t, 0, 0.02, 0.08, height - t, frame_mat)
    inner_h = height - t - 0.08
    # The spine façade sits 8 cm behind the front; shelf boards in front of it line up with its rows.
    lface(s, "books", origin, facing, 0, depth - 0.08, 0.08 + inner_h / 2, width - 2 * t, inner_h, 0.05,
          s.tex_material(books_tex))
    for k in range(1, 4):
        z = 0.08 + inner_h * k / 4
        lbox(s, "shelf", origin, facing, -w2 + t, w2 - t, depth - 0.1, depth, z - 0.025, z, frame_mat)


def wall_line(s, axis, coord, a0, a1, sides, doors=(), z1=2.5, half=0.06, lintel_z=2.1,
              lintel_rgba=(0.92, 0.92, 0.9, 1)):
    """Wall along x (axis="x": y = coord, running x a0..a1) or along y (axis="y": x = coord).

    `sides` lists (normal_sign, material) for the faces to build: +1 faces +y (or +x). Each face box is
    `half` thick on its side of the line, so an interior wall with both sides is 2*half thick. `doors`
    are (d0, d1) openings along the run; a lintel spans each from lintel_z to z1."""
    cuts = sorted(doors)
    pieces = []
    start = a0
    for d0, d1 in cuts:
        if d0 > start:
            pieces.append((start, d0))
        start = d1
    if a1 > start:
        pieces.append((start, a1))
    for sign, material in sides:
        for p0, p1 in pieces:
            if axis == "x":
                s.wall(p0, coord + sign * half, p1, coord + sign * half, (0, sign), material, z1=z1, thickness=half)
            else:
                s.wall(coord + sign * half, p0, coord + sign * half, p1, (sign, 0), material, z1=z1, thickness=half)
    thick_lo = -half if any(sg < 0 for sg, _ in sides) else 0.0
    thick_hi = half if any(sg > 0 for sg, _ in sides) else 0.0
    for d0, d1 in cuts:
        if axis == "x":
            s.box("lintel", (d0, coord + thick_lo, lintel_z), (d1, coord + thick_hi, z1), rgba=lintel_rgba)
        else:
            s.box("lintel", (coord + thick_lo, d0, lintel_z), (coord + thick_hi, d1, z1), rgba=lintel_rgba)


def sofa(s, origin, facing, width, fabric_mat, base_mat):
    w2 = width / 2
    fbox(s, "sofa", origin, facing, -w2, w2, 0.2, 0.9, 0.08, 0.42, fabric_mat)           # seat block
    fbox(s, "sofa", origin, facing, -w2, w2, 0.0, 0.22, 0.08, 0.85, fabric_mat)          # back
    fbox(s, "sofa", origin, facing, -w2, -w2 + 0.18, 0.2, 0.9, 0.08, 0.62, fabric_mat)   # arms
    fbox(s, "sofa", origin, facing, w2 - 0.18, w2, 0.2, 0.9, 0.08, 0.62, fabric_mat)
    lbox(s, "sofa", origin, facing, -w2 + 0.05, w2 - 0.05, 0.05, 0.85, 0.0, 0.08, base_mat)
    for k in range(3):  # cushions
        u = -w2 + 0.2 + k * (width - 0.4) / 3
        fbox(s, "sofa", origin, facing, u + 0.02, u + (width - 0.4) / 3 - 0.02, 0.22, 0.36, 0.42, 0.8, fabric_mat)


def table(s, centre, sx, sy, height, top_mat, leg_rgba=(0.25, 0.2, 0.15, 1)):
    x, y = centre
    s.box("table", (x - sx / 2, y - sy / 2, height - 0.04), (x + sx / 2, y + sy / 2, height), material=top_mat)
    for dx in (-1, 1):
        for dy in (-1, 1):
            lx, ly = x + dx * (sx / 2 - 0.06), y + dy * (sy / 2 - 0.06)
            s.box("table", (lx - 0.025, ly - 0.025, 0), (lx + 0.025, ly + 0.025, height - 0.04), rgba=leg_rgba)


def cabinet_run(s, origin, facing, u0, u1, depth, height, front_mat, top_mat=None, units=None,
                handle_rgba=(0.7, 0.7, 0.72, 1)):
    """Base cabinets with textured fronts, a top and handles; `units` gives the widths of the doors."""
    fbox(s, "cabinet", origin, facing, u0, u1, 0.0, depth, 0.0, height, front_mat)
    if top_mat:
        lbox(s, "cabinet", origin, facing, u0 - 0.01, u1 + 0.01, 0.0, depth + 0.03, height, height + 0.04, top_mat)
    u = u0
    for w in units or []:
        hz = height - 0.12
        lbox(s, "cabinet", origin, facing, u + w - 0.08, u + w - 0.06, depth, depth + 0.02, hz - 0.12, hz,
             rgba=handle_rgba)
        u += w


def bed(s, origin, facing, width, length, fabric_mat, frame_mat):
    w2 = width / 2
    lbox(s, "bed", origin, facing, -w2, w2, 0.0, length, 0.0, 0.3, frame_mat)
    lbox(s, "bed", origin, facing, -w2 + 0.03, w2 - 0.03, 0.05, length - 0.03, 0.3, 0.5, fabric_mat)
    fbox(s, "bed", origin, facing, -w2, w2, 0.0, 0.06, 0.0, 1.0, frame_mat)   # headboard
    fbox(s, "bed", origin, facing, -w2 + 0.1, -0.05, 0.08, 0.45, 0.5, 0.62, fabric_mat)  # pillows
    fbox(s, "bed", origin, facing, 0.05, w2 - 0.1, 0.08, 0.45, 0.5, 0.62, fabric_mat)


def desk(s, origin, facing, width, depth, top_mat, leg_mat, drawer_mat):
    w2 = width / 2
    lbox(s, "desk", origin, facing, -w2, w2, 0, depth, 0.72, 0.75, top_mat)
    for u in (-w2 + 0.03, w2 - 0.07):
        for v in (0.03, depth - 0.07):
            lbox(s, "desk", origin, facing, u, u + 0.04, v, v + 0.04, 0, 0.72, leg_mat)
    # Drawer pedestal with three drawer fronts and handles.
    fbox(s, "desk", origin, facing, w2 - 0.5, w2 - 0.08, 0.05, depth - 0.05, 0.05, 0.7, drawer_mat)
    for k in range(3):
        z = 0.1 + k * 0.2
        lbox(s, "desk", origin, facing, w2 - 0.4, w2 - 0.18, depth - 0.05, depth - 0.03, z + 0.1, z + 0.12,
             rgba=(0.75, 0.75, 0.78, 1))


def chair(s, centre, facing, fabric_mat):
    lbox(s, "chair", centre, facing, -0.22, 0.22, -0.22, 0.22, 0.42, 0.48, fabric_mat)
    fbox(s, "chair", centre, facing, -0.22, 0.22, -0.26, -0.2, 0.48, 0.95, fabric_mat)
    s.geom("chair", "cylinder", (centre[0], centre[1], 0.22), (0.025, 0.2), rgba=(0.2, 0.2, 0.22, 1))
    for k in range(5):
        a = 2 * math.pi * k / 5
        s.geom("chair", "box", (centre[0] + 0.14 * math.cos(a), centre[1] + 0.14 * math.sin(a), 0.04),
               (0.15, 0.02, 0.015), euler=(0, 0, math.degrees(a)), rgba=(0.15, 0.15, 0.17, 1))


def plant(s, centre, pot_r, height, leaves_mat, pot_rgba=(0.62, 0.3, 0.18, 1)):
    """A potted plant: pot, stem and a crown of randomly tilted leaf panels (textured on both faces)."""
    x, y = centre
    s.geom("plant", "cylinder", (x, y, 0.18), (pot_r, 0.18), rgba=pot_rgba)
    s.geom("plant", "cylinder", (x, y, 0.37), (pot_r + 0.02, 0.02), rgba=pot_rgba)
    s.geom("plant", "cylinder", (x, y, 0.37 + (height - 0.37) / 2), (0.015, (height - 0.37) / 2),
           rgba=(0.35, 0.25, 0.12, 1))
    rng = random.Random(int(x * 1000 + y * 10))
    for k in range(9):
        a = 2 * math.pi * k / 9 + rng.uniform(-0.3, 0.3)
        r = pot_r * rng.uniform(0.4, 1.2)
        cz = 0.5 + (height - 0.5) * rng.uniform(0.3, 0.95)
        size = rng.uniform(0.12, 0.22)
        s.geom("plant", "box", (x + r * math.cos(a), y + r * math.sin(a), cz), (size, size * 0.6, 0.004),
               material=leaves_mat, euler=(rng.uniform(-60, 60), rng.uniform(-60, 60), math.degrees(a)),
               collide=False)


def carton(s, lo, hi, facing, carton_tex):
    """A cardboard box with its label on the faces toward ±facing (other faces show the rim colour)."""
    cx, cy, cz = [(a + b) / 2 for a, b in zip(lo, hi)]
    sx, sy, sz = [abs(b - a) / 2 for a, b in zip(lo, hi)]
    fx, fy = facing
    # local z along facing, local y up, local x across.
    x = cross((0, 0, 1), (fx, fy, 0))
    half_across = sx if abs(fy) > 0.5 else sy
    half_depth = sy if abs(fy) > 0.5 else sx
    s.geom("carton", "box", (cx, cy, cz), (half_across, sz, half_depth), material=s.tex_material(carton_tex),
           xyaxes=tuple(x) + (0, 0, 1))


def frame_poster(s, centre, normal, width, height, tex):
    """A poster or picture hanging on a wall (flat, no collision); `centre` is on the wall's face."""
    n = normalise(normal)
    c = [centre[i] + n[i] * 0.012 for i in range(3)]
    s.face("poster", c, normal, width, height, 0.01, s.tex_material(tex), collide=False)


# ---------------------------------------------------------------------------------------------------
# Scenes.

def office():
    s = Scene("fleetslam_office", """
        Office: one room x 0..6, y 0..5, walls 2.5 m high (ceiling at 2.5). Free floor: x 1.1..4.9, y 1.3..3.7
        (see scenes/README.md). Desk along the south wall, bookshelves on the north and east walls,
        whiteboard on the west wall, door on the east wall.""")
    W, D, H = 6.0, 5.0, 2.5
    s.light((3, 2.5, 2.4), (0.35, 0.25, -1), (0.45, 0.45, 0.42), ambient=(0.25, 0.25, 0.25))
    s.light((3, 2.5, 2.4), (-0.4, -0.3, -1), (0.35, 0.35, 0.35))
    s.light((3, 2.5, 2.4), (0.1, -0.6, -0.5), (0.2, 0.2, 0.22))
    s.comment_line("floor and ceiling")
    s.floor_patch(0, 0, W, D, s.tex_material("floor_wood_oak"))
    s.ceiling(0, 0, W, D, H, s.material("m_ceiling", "ceiling_tiles", texrepeat=(3, 2.5)))
    s.comment_line("walls: faces at x=0, x=6, y=0, y=5, 6 cm thick behind the face")
    s.wall(0, 0, 3, 0, (0, 1), s.tex_material("wall_office_a"))
    s.wall(3, 0, 6, 0, (0, 1), s.tex_material("wall_brick"))
    s.wall(0, 5, 3.5, 5, (0, -1), s.tex_material("wall_office_b"))
    s.wall(3.5, 5, 6, 5, (0, -1), s.tex_material("wall_plaster_yellow"))
    s.wall(0, 0, 0, 5, (1, 0), s.tex_material("wall_plaster_yellow", suffix="_w"))
    s.wall(6, 0, 6, 5, (-1, 0), s.tex_material("wall_office_a", suffix="_e"))
    s.comment_line("door (east wall), whiteboard (west wall), posters and pictures")
    s.face("door", (5.97, 3.9, 1.05), (-1, 0, 0), 0.9, 2.1, 0.02, s.tex_material("door"), collide=False)
    s.face("whiteboard", (0.02, 2.4, 1.4), (1, 0, 0), 2.0, 1.0, 0.02, s.tex_material("whiteboard", specular=0.3),
           collide=False)
    frame_poster(s, (0.0, 0.8, 1.3), (1, 0, 0), 0.6, 0.6, "poster_0")
    frame_poster(s, (0.0, 4.1, 1.0), (1, 0, 0), 0.7, 0.7, "poster_1")
    frame_poster(s, (3.4, 0.0, 1.2), (0, 1, 0), 0.8, 0.8, "poster_2")
    frame_poster(s, (5.0, 0.0, 1.0), (0, 1, 0), 0.9, 0.675, "picture_0")
    frame_poster(s, (4.6, 5.0, 1.5), (0, -1, 0), 0.8, 0.6, "picture_1")
    frame_poster(s, (6.0, 2.2, 1.3), (-1, 0, 0), 0.6, 0.6, "poster_3")
    s.comment_line("desk with monitor, keyboard, mug, lamp and papers (south wall, x 0.6..2.4)")
    wood = s.tex_material("wood_light")
    dark = s.tex_material("wood_dark")
    desk(s, (1.5, 0.05), (0, 1), 1.8, 0.75, wood, s.colour("metal", (0.3, 0.3, 0.32, 1)), dark)
    s.box("monitor", (1.2, 0.25, 0.75), (1.3, 0.32, 0.9), rgba=(0.1, 0.1, 0.1, 1))
    s.face("monitor", (1.25, 0.38, 1.08), (0, 1, 0), 0.62, 0.39, 0.05, s.tex_material("screen_0", specular=0.3))
    s.face("monitor", (1.9, 0.36, 1.02), (0, 1, 0), 0.45, 0.28, 0.04, s.tex_material("screen_1", specular=0.3))
    s.box("keyboard", (1.05, 0.45, 0.75), (1.5, 0.6, 0.77), rgba=(0.15, 0.15, 0.17, 1))
    s.geom("mug", "cylinder", (0.8, 0.55, 0.8), (0.04, 0.05), rgba=(0.8, 0.15, 0.1, 1))
    s.geom("lamp", "cylinder", (2.25, 0.25, 0.76), (0.08, 0.01), rgba=(0.1, 0.3, 0.5, 1))
    s.geom("lamp", "cylinder", (2.25, 0.25, 0.95), (0.012, 0.2), rgba=(0.1, 0.3, 0.5, 1))
    s.geom("lamp", "cylinder", (2.25, 0.32, 1.15), (0.07, 0.05), rgba=(0.95, 0.8, 0.2, 1), euler=(60, 0, 0))
    for k, (x0, x1, h, c) in enumerate([(0.7, 0.95, 0.04, (0.2, 0.4, 0.7, 1)), (0.72, 0.92, 0.03, (0.8, 0.7, 0.2, 1)),
                                        (0.69, 0.96, 0.05, (0.3, 0.6, 0.3, 1))]):
        z = 0.75 + sum([0.04, 0.03, 0.05][:k])
        s.box("paper", (x0, 0.15, z), (x1, 0.45, z + h), rgba=c)
    chair(s, (1.3, 1.05), (0, -1), s.tex_material("fabric_teal"))
    s.comment_line("bookshelves (north wall x 0.4..2.4; east wall y 0.6..1.8), filing cabinet, boxes, plants")
    frame = s.tex_material("wood_dark", suffix="_frame")
    bookshelf(s, (0.9, 5.0), (0, -1), 1.0, 2.0, 0.35, "books_0", frame)
    bookshelf(s, (1.95, 5.0), (0, -1), 1.0, 2.0, 0.35, "books_1", frame)
    bookshelf(s, (6.0, 1.2), (-1, 0), 1.2, 1.6, 0.35, "books_2", frame)
    fbox(s, "cabinet", (2.95, 5.0), (0, -1), -0.25, 0.25, 0.0, 0.55, 0.0, 1.3, s.tex_material("cabinet_metal"))
    carton(s, (4.9, 4.3, 0), (5.5, 4.8, 0.45), (0, -1), "carton_0")
    carton(s, (5.0, 4.35, 0.45), (5.45, 4.75, 0.75), (-1, 0), "carton_3")
    carton(s, (4.3, 0.1, 0), (4.8, 0.5, 0.4), (0, 1), "carton_6")
    plant(s, (0.35, 0.35), 0.16, 1.3, s.tex_material("leaves"))
    plant(s, (5.6, 0.4), 0.18, 1.5, s.tex_material("leaves"))
    plant(s, (0.35, 4.5), 0.14, 1.1, s.tex_material("leaves"))
    s.comment_line("side table with printer (west wall, y 3.2..3.8)")
    fbox(s, "table", (0.0, 3.5), (1, 0), -0.3, 0.3, 0.0, 0.5, 0.0, 0.7, s.tex_material("wood_light", suffix="_t"))
    s.box("printer", (0.05, 3.3, 0.7), (0.45, 3.7, 0.95), rgba=(0.85, 0.85, 0.83, 1))
    s.face("printer", (0.45, 3.5, 0.82), (1, 0, 0), 0.3, 0.18, 0.005, s.tex_material("carton_9"), collide=False)
    s.comment_line("rug (flat, no collision)")
    s.face("rug", (3.0, 2.5, 0.003), (0, 0, 1), 2.2, 1.6, 0.003, s.tex_material("rug"), up=(0, 1, 0), collide=False)
    return s


def apartment():
    s = Scene("fleetslam_apartment", """
        Apartment: x 0..11, y 0..9.8, walls 2.5 m high, ceiling at 2.5. Rooms (wall centre lines, walls 12 cm thick):
        living x 0..6 y 0..4 | kitchen x 6..11 y 0..4 | corridor x 0..11 y 4..5.8 | bedroom x 0..5.5 y 5.8..9.8 |
        study x 5.5..11 y 5.8..9.8. Doorways 1.0 m wide (lintel at 2.1): living-corridor x 2..3 on y=4,
        kitchen-corridor x 8..9 on y=4, living-kitchen y 1.5..2.5 on x=6, bedroom-corridor x 3..4 on y=5.8,
        study-corridor x 7..8 on y=5.8. See scenes/README.md for the free areas.""")
    H = 2.5
    C0, C1, N1 = 4.0, 5.8, 9.8  # corridor y range, north wall
    t = 0.06                    # half wall thickness
    s.light((5.5, 4.9, 2.4), (0.35, 0.25, -1), (0.45, 0.45, 0.42), ambient=(0.25, 0.25, 0.25))
    s.light((5.5, 4.9, 2.4), (-0.4, -0.3, -1), (0.35, 0.35, 0.35))
    s.light((5.5, 4.9, 2.4), (0.1, -0.6, -0.5), (0.2, 0.2, 0.22))

    living = s.tex_material("wall_wallpaper_warm")
    living_b = s.tex_material("wall_brick")
    kitchen = s.tex_material("wall_kitchen_tiles")
    corridor = s.tex_material("wall_plaster_green")
    bedroom = s.tex_material("wall_wallpaper_cool")
    study = s.tex_material("wall_plaster_yellow")
    study_b = s.tex_material("wall_office_b")

    s.comment_line("floors (one patch per room, texture scale about 2.7 m) and ceiling")
    s.floor_patch(0, 0, 6, C0, s.material("m_floor_living", "floor_wood_oak", texrepeat=(2, 1.5)), name="floor_living")
    s.floor_patch(6, 0, 11, C0, s.tex_material("floor_stone_tiles"), name="floor_kitchen")
    s.floor_patch(0, C0, 11, C1, s.material("m_floor_corridor", "floor_wood_walnut", texrepeat=(4, 0.66)),
                  name="floor_corridor")
    s.floor_patch(0, C1, 5.5, N1, s.material("m_floor_bedroom", "floor_carpet_blue", texrepeat=(2, 1.5)),
                  name="floor_bedroom")
    s.floor_patch(5.5, C1, 11, N1, s.material("m_floor_study", "floor_wood_walnut", texrepeat=(2, 1.5)),
                  name="floor_study")
    s.ceiling(0, 0, 11, N1, H, s.material("m_ceiling", None, rgba=(0.93, 0.93, 0.9, 1)))

    s.comment_line("exterior walls")
    wall_line(s, "x", 0.0, 0, 6, [(1, living_b)])
    wall_line(s, "x", 0.0, 6, 11, [(1, kitchen)])
    wall_line(s, "x", N1, 0, 5.5, [(-1, bedroom)])
    wall_line(s, "x", N1, 5.5, 11, [(-1, study_b)])
    wall_line(s, "y", 0.0, 0, C0, [(1, living)])
    wall_line(s, "y", 0.0, C0, C1, [(1, corridor)])
    wall_line(s, "y", 0.0, C1, N1, [(1, bedroom)])
    wall_line(s, "y", 11.0, 0, C0, [(-1, kitchen)])
    wall_line(s, "y", 11.0, C0, C1, [(-1, corridor)])
    wall_line(s, "y", 11.0, C1, N1, [(-1, study)])
    s.comment_line("interior walls with doorways")
    wall_line(s, "x", C0, 0, 6, [(-1, living), (1, corridor)], doors=[(2.0, 3.0)])
    wall_line(s, "x", C0, 6, 11, [(-1, kitchen), (1, corridor)], doors=[(8.0, 9.0)])
    wall_line(s, "x", C1, 0, 5.5, [(1, bedroom), (-1, corridor)], doors=[(3.0, 4.0)])
    wall_line(s, "x", C1, 5.5, 11, [(1, study), (-1, corridor)], doors=[(7.0, 8.0)])
    wall_line(s, "y", 6.0, 0, C0, [(-1, living), (1, kitchen)], doors=[(1.5, 2.5)])
    wall_line(s, "y", 5.5, C1, N1, [(-1, bedroom), (1, study)])

    s.comment_line("living room: sofa facing a TV unit, coffee table, rug, shelf, plants, pictures")
    sofa(s, (3.0, 0.0), (0, 1), 2.2, s.tex_material("fabric_red"), s.colour("dark_wood", (0.25, 0.17, 0.1, 1)))
    table(s, (3.0, 1.45), 1.1, 0.55, 0.42, s.tex_material("wood_light"))
    s.face("rug", (3.0, 1.5, 0.003), (0, 0, 1), 2.4, 1.3, 0.003, s.tex_material("rug"), up=(0, 1, 0),
           collide=False)
    cabinet_run(s, (0.0, 2.0), (1, 0), -0.9, 0.9, 0.45, 0.5, s.tex_material("wood_dark"), units=[0.6, 0.6, 0.6])
    s.face("tv", (0.25, 2.0, 0.95), (1, 0, 0), 1.1, 0.62, 0.05, s.tex_material("picture_2", specular=0.3))
    bookshelf(s, (4.9, C0 - t), (0, -1), 1.0, 1.9, 0.32, "books_3", s.tex_material("wood_dark", suffix="_f"))
    plant(s, (0.45, 0.45), 0.18, 1.4, s.tex_material("leaves"))
    plant(s, (5.5, 0.45), 0.16, 1.2, s.tex_material("leaves"))
    frame_poster(s, (1.2, C0 - t, 1.5), (0, -1, 0), 0.8, 0.6, "picture_3")
    frame_poster(s, (4.0, 0.0, 1.5), (0, 1, 0), 0.7, 0.7, "poster_4")
    frame_poster(s, (6.0 - t, 0.8, 1.2), (-1, 0, 0), 0.6, 0.6, "poster_5")

    s.comment_line("kitchen: counters along the south and east walls, fridge, wall cupboards, dining table")
    front = s.tex_material("wood_light", suffix="_k")
    top = s.colour("counter", (0.3, 0.3, 0.32, 1), specular=0.3)
    cabinet_run(s, (8.4, 0.0), (0, 1), -2.1, 2.1, 0.6, 0.88, front, top, units=[0.6, 0.8, 0.6, 0.5, 0.8, 0.8])
    cabinet_run(s, (11.0, 2.3), (-1, 0), -0.9, 0.9, 0.6, 0.88, front, top, units=[0.7, 0.5, 0.6])
    s.box("stove", (8.2, 0.05, 0.92), (8.8, 0.55, 0.93), rgba=(0.05, 0.05, 0.05, 1))
    fbox(s, "fridge", (6.45, 0.0), (0, 1), -0.35, 0.35, 0.0, 0.65, 0.0, 1.85, s.tex_material("poster_6"))
    for k in range(3):
        fbox(s, "cupboard", (7.7 + k * 0.8, 0.0), (0, 1), -0.38, 0.38, 0.0, 0.35, 1.45, 2.1, front)
    table(s, (9.55, 2.3), 0.9, 0.7, 0.75, front)
    for (cx, cy, fx, fy) in [(9.3, 1.82, 0, 1), (9.8, 1.82, 0, 1), (9.3, 2.78, 0, -1), (9.8, 2.78, 0, -1)]:
        lbox(s, "kchair", (cx, cy), (fx, fy), -0.19, 0.19, -0.19, 0.19, 0.42, 0.46, s.colour("chair", (0.55, 0.3, 0.12, 1)))
        for dx in (-0.16, 0.16):
            for dy in (-0.16, 0.16):
                s.box("kchair", (cx + dx - 0.015, cy + dy - 0.015, 0), (cx + dx + 0.015, cy + dy + 0.015, 0.42),
                      rgba=(0.3, 0.18, 0.08, 1))
        fbox(s, "kchair", (cx, cy), (fx, fy), -0.19, 0.19, -0.21, -0.17, 0.46, 0.85, s.tex_material("fabric_teal"))
    frame_poster(s, (10.0, C0 - t, 1.5), (0, -1, 0), 0.7, 0.7, "poster_7")

    s.comment_line("corridor: entrance door (west end), door at the east end, shoe cabinet, pictures")
    s.face("door", (0.02, (C0 + C1) / 2, 1.05), (1, 0, 0), 0.9, 2.1, 0.02, s.tex_material("door"), collide=False)
    s.face("door", (10.98, (C0 + C1) / 2, 1.05), (-1, 0, 0), 0.9, 2.1, 0.02, s.tex_material("door"), collide=False)
    fbox(s, "shoes", (5.3, C1 - t), (0, -1), -0.5, 0.5, 0.0, 0.3, 0.0, 0.5, s.tex_material("carton_8"))
    frame_poster(s, (1.2, C1 - t, 1.4), (0, -1, 0), 0.6, 0.45, "picture_1")
    frame_poster(s, (6.0, C0 + t, 1.4), (0, 1, 0), 0.6, 0.6, "poster_1")
    frame_poster(s, (9.8, C1 - t, 1.4), (0, -1, 0), 0.6, 0.45, "picture_0")
    frame_poster(s, (4.4, C0 + t, 1.0), (0, 1, 0), 0.5, 0.5, "poster_2")

    s.comment_line("bedroom: bed, nightstands, wardrobe, desk, poster, box, plant")
    bed(s, (2.4, N1 - t), (0, -1), 1.6, 2.0, s.tex_material("fabric_teal", suffix="_b"),
        s.tex_material("wood_dark", suffix="_b"))
    for x in (1.3, 3.5):
        fbox(s, "nightstand", (x, N1 - t), (0, -1), -0.22, 0.22, 0.0, 0.4, 0.0, 0.55,
             s.tex_material("wood_light", suffix="_n"))
    fbox(s, "wardrobe", (5.5 - t, 8.5), (-1, 0), -0.9, 0.9, 0.0, 0.6, 0.0, 2.1, s.tex_material("door", suffix="_w"))
    desk(s, (0.0, 6.9), (1, 0), 1.2, 0.6, s.tex_material("wood_light", suffix="_n"),
         s.colour("metal", (0.3, 0.3, 0.32, 1)), s.tex_material("wood_dark", suffix="_b"))
    frame_poster(s, (0.0, 8.5, 1.3), (1, 0, 0), 0.6, 0.6, "poster_0")
    carton(s, (4.7, C1 + t + 0.05, 0), (5.3, C1 + 0.6, 0.45), (-1, 0), "carton_4")
    plant(s, (0.45, C1 + 0.45), 0.14, 1.0, s.tex_material("leaves"))

    s.comment_line("study: bookshelves, desk with a screen, chair, boxes, whiteboard, plant")
    frame = s.tex_material("wood_dark", suffix="_s")
    bookshelf(s, (7.0, N1 - t), (0, -1), 1.0, 2.0, 0.35, "books_0", frame)
    bookshelf(s, (8.05, N1 - t), (0, -1), 1.0, 2.0, 0.35, "books_2", frame)
    bookshelf(s, (11.0, 8.6), (-1, 0), 1.0, 1.8, 0.35, "books_1", frame)
    desk(s, (11.0, 6.8), (-1, 0), 1.4, 0.7, s.tex_material("wood_light", suffix="_s"),
         s.colour("metal", (0.3, 0.3, 0.32, 1)), frame)
    s.face("monitor", (10.62, 6.8, 1.05), (-1, 0, 0), 0.6, 0.37, 0.04, s.tex_material("screen_0", specular=0.3))
    s.face("whiteboard", (5.5 + t + 0.02, 7.8, 1.4), (1, 0, 0), 1.6, 0.8, 0.02,
           s.tex_material("whiteboard", specular=0.3), collide=False)
    chair(s, (10.1, 6.8), (1, 0), s.tex_material("fabric_red", suffix="_s"))
    carton(s, (5.95, N1 - 0.5, 0), (6.45, N1 - t, 0.4), (0, -1), "carton_7")
    carton(s, (6.0, N1 - 0.45, 0.4), (6.4, N1 - 0.1, 0.7), (1, 0), "carton_1")
    plant(s, (10.5, N1 - 0.45), 0.16, 1.3, s.tex_material("leaves"))
    return s


# Warehouse layout, shared with the README: rack rows (y bands) and segments (x ranges).
WAREHOUSE_ROWS = [("A", 2.0, 3.0), ("B", 5.0, 6.0), ("C", 8.0, 9.0), ("D", 11.0, 12.0)]
WAREHOUSE_SEGMENTS = [(1, 3.0, 9.0), (2, 11.0, 17.0)]


def rack_segment(s, rng, code, x0, x1, y0, y1, carton_textures):
    """A pallet rack: blue uprights every 2 m, orange beams at 4 levels, decks, cartons and pallets."""
    s.comment_line("rack %s: x %s..%s, y %s..%s" % (code, f(x0), f(x1), f(y0), f(y1)))
    upright = s.colour("rack_upright", (0.1, 0.25, 0.6, 1), specular=0.3)
    beam = s.colour("rack_beam", (0.95, 0.45, 0.05, 1), specular=0.3)
    deck = s.colour("rack_deck", (0.55, 0.55, 0.57, 1))
    pallet = s.tex_material("wood_light", suffix="_pallet")
    levels = [0.12, 1.15, 2.15, 3.1]
    bays = int(round((x1 - x0) / 2.0))
    for k in range(bays + 1):
        x = x0 + k * (x1 - x0) / bays
        for y in (y0 + 0.04, y1 - 0.04):
            s.box("upright", (x - 0.04, y - 0.04, 0), (x + 0.04, y + 0.04, 3.3), material=upright)
    # A plinth along the whole row: the ground level is stored on it and nothing drives through a rack.
    s.box("plinth", (x0 - 0.04, y0, 0), (x1 + 0.04, y1, levels[0]), material=deck)
    for z in levels[1:]:
        for y in (y0, y1 - 0.06):
            s.box("beam", (x0, y, z - 0.1), (x1, y + 0.06, z), material=beam)
        s.box("deck", (x0 + 0.04, y0 + 0.06, z - 0.03), (x1 - 0.04, y1 - 0.06, z), material=deck, collide=False)
    # Cartons (some on pallets), packed with gaps; the label faces one of the two aisles.
    for b in range(bays):
        bx0 = x0 + b * (x1 - x0) / bays + 0.08
        bx1 = x0 + (b + 1) * (x1 - x0) / bays - 0.08
        for li, z in enumerate(levels[:3]):
            clearance = levels[li + 1] - 0.12 - z if li + 1 < len(levels) else 0.9
            x = bx0 + rng.uniform(0.0, 0.2)
            on_pallet = li == 0 and rng.random() < 0.6
            base = z
            if on_pallet:
                base = z + 0.12
                clearance -= 0.12
                s.box("pallet", (bx0 + 0.05, y0 + 0.1, z), (bx1 - 0.05, y1 - 0.1, base), material=pallet)
            while True:
                w = rng.uniform(0.35, 0.85)
                if x + w > bx1:
                    break
                if rng.random() < 0.15:  # an empty slot
                    x += w
                    continue
                h = rng.uniform(0.3, clearance - 0.05)
                d = rng.uniform(0.55, 0.85)
                yc = (y0 + y1) / 2 + rng.uniform(-0.05, 0.05)
                facing = (0, -1) if rng.random() < 0.5 else (0, 1)
                carton(s, (x, yc - d / 2, base), (x + w, yc + d / 2, base + h), facing, rng.choice(carton_textures))
                if h < clearance / 2 - 0.05 and rng.random() < 0.5:  # a second box on top
                    w2 = w * rng.uniform(0.6, 0.95)
                    h2 = rng.uniform(0.2, clearance - h - 0.05)
                    carton(s, (x, yc - d / 2 + 0.05, base + h), (x + w2, yc + d / 2 - 0.05, base + h + h2), facing,
                           rng.choice(carton_textures))
                x += w + rng.uniform(0.03, 0.15)


def warehouse():
    s = Scene("fleetslam_warehouse", """
        Warehouse: x 0..20, y 0..15, walls 6 m high. Four rack rows A..D (y 2..3, 5..6, 8..9, 11..12), each in two
        segments (x 3..9 and 11..17, cross aisle x 9..11), racks 3.3 m high with four levels. Aisles 2 m wide:
        y 0..2 (along the south wall), 3..5, 6..8, 9..11; loading area y 12..15; end aisles x 0..3 and 17..20.
        Pillars at the row ends. See scenes/README.md for the free areas.""")
    rng = random.Random(20240601)
    H = 6.0
    s.light((10, 7.5, 5.8), (0.35, 0.25, -1), (0.45, 0.45, 0.42), ambient=(0.28, 0.28, 0.28))
    s.light((10, 7.5, 5.8), (-0.4, -0.3, -1), (0.35, 0.35, 0.35))
    s.light((10, 7.5, 5.8), (0.1, -0.6, -0.5), (0.2, 0.2, 0.22))

    s.comment_line("floor: 5 m concrete slabs (two textures, turned) and ceiling")
    for i in range(4):
        for j in range(3):
            tex = "floor_concrete_a" if (i + j) % 2 == 0 else "floor_concrete_b"
            turn = (i * 3 + j * 2) % 4
            ax = [(1, 0, 0, 0, 1, 0), (0, 1, 0, -1, 0, 0), (-1, 0, 0, 0, -1, 0), (0, -1, 0, 1, 0, 0)][turn]
            s.geom("floor", "plane", (2.5 + 5 * i, 2.5 + 5 * j, 0), (2.5, 2.5, 0.1), material=s.tex_material(tex),
                   xyaxes=ax, name="floor_%d_%d" % (i, j))
    s.ceiling(0, 0, 20, 15, H, s.material("m_ceiling", None, rgba=(0.55, 0.55, 0.57, 1)))

    s.comment_line("walls: a textured band 0..3 m in segments, plain concrete above")
    upper = s.colour("wall_upper", (0.62, 0.63, 0.62, 1))
    segs = [((0, 0), (5, 0), (0, 1), "G"), ((5, 0), (10, 0), (0, 1), "H"), ((10, 0), (15, 0), (0, 1), "A"),
            ((15, 0), (20, 0), (0, 1), "B"),
            ((20, 0), (20, 5), (-1, 0), "C"), ((20, 5), (20, 10), (-1, 0), "D"), ((20, 10), (20, 15), (-1, 0), "E"),
            ((20, 15), (15, 15), (0, -1), "F"), ((15, 15), (10, 15), (0, -1), "G"), ((10, 15), (5, 15), (0, -1), "H"),
            ((5, 15), (0, 15), (0, -1), "A"),
            ((0, 15), (0, 10), (1, 0), "B"), ((0, 10), (0, 5), (1, 0), "C"), ((0, 5), (0, 0), (1, 0), "D")]
    # Each zone texture appears at most twice, on walls far apart.
    for (a, b, n, zone) in segs:
        s.wall(a[0], a[1], b[0], b[1], n, s.tex_material("wall_blocks_" + zone), z0=0, z1=3.0, thickness=0.2)
        s.wall(a[0], a[1], b[0], b[1], n, upper, z0=3.0, z1=H, thickness=0.2)

    s.comment_line("rack rows")
    cartons = ["carton_%d" % i for i in range(16)]
    for row, y0, y1 in WAREHOUSE_ROWS:
        for seg, x0, x1 in WAREHOUSE_SEGMENTS:
            rack_segment(s, rng, "%s%d" % (row, seg), x0, x1, y0, y1, cartons)
            # Row/segment signs on both end uprights, facing the end and cross aisles.
            yc = (y0 + y1) / 2
            s.face("sign", (x0 - 0.05, yc, 1.4), (-1, 0, 0), 0.6, 0.3, 0.02, s.tex_material("sign_%s%d" % (row, seg)),
                   collide=False)
            s.face("sign", (x1 + 0.05, yc, 1.4), (1, 0, 0), 0.6, 0.3, 0.02, s.tex_material("sign_%s%d" % (row, seg)),
                   collide=False)

    s.comment_line("pillars at the outer row ends (0.4 m square, hazard band)")
    concrete = s.colour("pillar", (0.7, 0.7, 0.68, 1))
    band = s.colour("hazard", (0.95, 0.8, 0.1, 1))
    for (px, py) in [(2.5, 2.5), (2.5, 8.5), (17.5, 5.5), (17.5, 11.5)]:
        s.box("pillar", (px - 0.2, py - 0.2, 0), (px + 0.2, py + 0.2, H), material=concrete)
        s.box("pillar", (px - 0.21, py - 0.21, 0.1), (px + 0.21, py + 0.21, 1.0), material=band)

    s.comment_line("floor markings: yellow aisle edges, white stop lines, row codes painted at aisle ends")
    yellow = s.colour("paint_yellow", (0.95, 0.8, 0.1, 1))
    white = s.colour("paint_white", (0.95, 0.95, 0.95, 1))
    for row, y0, y1 in WAREHOUSE_ROWS:
        for seg, x0, x1 in WAREHOUSE_SEGMENTS:
            for y in (y0 - 0.15, y1 + 0.15):
                s.box("marking", (x0, y - 0.04, 0), (x1, y + 0.04, 0.002), material=yellow, collide=False)
    for y0, y1 in [(0.2, 1.8), (3.2, 4.8), (6.2, 7.8), (9.2, 10.8)]:
        for x in (2.9, 17.1):
            s.box("marking", (x - 0.05, y0, 0), (x + 0.05, y1, 0.002), material=white, collide=False)
    for (row, y0, y1), aisle_y in zip(WAREHOUSE_ROWS, [1.0, 4.0, 7.0, 10.0]):
        s.face("decal", (2.2, aisle_y, 0.002), (0, 0, 1), 0.8, 0.4, 0.002, s.tex_material("sign_%s1" % row),
               up=(1, 0, 0), collide=False)
        s.face("decal", (17.8, aisle_y, 0.002), (0, 0, 1), 0.8, 0.4, 0.002, s.tex_material("sign_%s2" % row),
               up=(-1, 0, 0), collide=False)
    for k in range(7):  # hatched no-parking zone in the loading area (irregular spacing)
        x = 12.0 + k * 0.45 + rng.uniform(-0.08, 0.08)
        s.geom("marking", "box", (x, 14.55, 0.001), (0.05, 0.42, 0.001), material=yellow, euler=(0, 0, 35),
               collide=False)

    s.comment_line("loading area (y > 14) and end aisles: pallets with cartons, forklift, workbench, bins")
    pallet = s.tex_material("wood_light", suffix="_pallet")
    for (px, n) in [(2.0, 3), (4.0, 2), (6.5, 4), (8.5, 1), (16.0, 3)]:
        s.box("pallet", (px - 0.6, 14.1, 0), (px + 0.6, 14.9, 0.14), material=pallet)
        z = 0.14
        for k in range(n):
            h = rng.uniform(0.3, 0.5)
            w = rng.uniform(0.8, 1.1)
            carton(s, (px - w / 2, 14.15, z), (px + w / 2, 14.85, z + h), (0, -1), rng.choice(cartons))
            z += h
    fork = s.colour("forklift", (0.95, 0.7, 0.05, 1), specular=0.3)
    black = s.colour("black", (0.08, 0.08, 0.08, 1))
    s.box("forklift", (10.2, 14.0, 0.15), (11.6, 14.9, 1.1), material=fork)
    s.box("forklift", (10.4, 14.1, 1.1), (11.0, 14.8, 2.1), material=black)
    s.box("forklift", (9.9, 14.1, 0.0), (10.2, 14.8, 2.4), material=black)
    for wx in (10.5, 11.3):
        for wy in (14.0, 14.9):
            s.geom("forklift", "cylinder", (wx, wy, 0.2), (0.2, 0.06), material=black, xyaxes=(1, 0, 0, 0, 0, 1))
    fbox(s, "bench", (13.8, 15.0), (0, -1), -0.8, 0.8, 0.0, 0.7, 0.0, 0.9, s.tex_material("wood_dark"))
    s.face("monitor", (13.6, 14.6, 1.15), (0, -1, 0), 0.55, 0.34, 0.04, s.tex_material("screen_1", specular=0.3))
    s.face("whiteboard", (18.0, 14.98, 1.5), (0, -1, 0), 2.0, 1.0, 0.02, s.tex_material("whiteboard", specular=0.3),
           collide=False)
    for (bx, by) in [(19.5, 14.4), (19.5, 0.5), (0.5, 0.5)]:
        s.geom("bin", "cylinder", (bx, by, 0.45), (0.3, 0.45), rgba=(0.1, 0.35, 0.15, 1))
    s.comment_line("on the walls: posters, doors, fire points")
    frame_poster(s, (0.0, 6.5, 1.6), (1, 0, 0), 0.8, 0.8, "poster_3")
    frame_poster(s, (20.0, 8.5, 1.6), (-1, 0, 0), 0.8, 0.8, "poster_4")
    frame_poster(s, (7.0, 0.0, 1.7), (0, 1, 0), 0.9, 0.9, "poster_5")
    s.face("door", (0.02, 12.5, 1.05), (1, 0, 0), 0.9, 2.1, 0.02, s.tex_material("door"), collide=False)
    s.face("door", (19.98, 2.5, 1.05), (-1, 0, 0), 0.9, 2.1, 0.02, s.tex_material("door"), collide=False)
    red = s.colour("fire", (0.8, 0.05, 0.05, 1), specular=0.3)
    for (fx, fy, n) in [(0.0, 3.8, (1, 0)), (20.0, 11.0, (-1, 0)), (12.5, 0.0, (0, 1))]:
        s.box("extinguisher", (fx - 0.12 if n[0] <= 0 else fx, fy - 0.12 if n[1] <= 0 else fy, 0.3),
              (fx + 0.12 if n[0] >= 0 else fx, fy + 0.12 if n[1] >= 0 else fy, 0.85), material=red)
    return s


def main():
    scenes = {"office": office, "apartment": apartment, "warehouse": warehouse}
    for name, build in scenes.items():
        s = build()
        s.write(os.path.join(HERE, name, name + ".xml"))


if __name__ == "__main__":
    main()
