// The mesh viewer: a finished session's mesh.ply drawn with three.js, grey = its multi-view AO
// (the `quality` of each vertex), lit by a headlight, turned and zoomed with the mouse.
import * as THREE from 'three';
import { PLYLoader } from '/vendor/PLYLoader.js';
import { OrbitControls } from '/vendor/OrbitControls.js';

let viewer = null;

function makeViewer(canvas) {
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setClearColor(0x181820);
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(45, canvas.width / canvas.height, 0.01, 100);
  const headlight = new THREE.DirectionalLight(0xffffff, 1.2);
  camera.add(headlight);
  scene.add(camera, new THREE.AmbientLight(0xffffff, 0.35));
  const controls = new OrbitControls(camera, canvas);
  const draw = () => {
    renderer.render(scene, camera);
    canvas.dataset.drawn = String(Number(canvas.dataset.drawn || 0) + 1);
  };
  controls.addEventListener('change', draw);
  return { renderer, scene, camera, controls, draw, mesh: null };
}

export async function showMesh(canvas, url) {
  if (!viewer) viewer = makeViewer(canvas);
  const loader = new PLYLoader();
  loader.setCustomPropertyNameMapping({ ao: ['quality'] });
  const geometry = await loader.loadAsync(url);
  const position = geometry.getAttribute('position');
  if (!position || position.count === 0) throw new Error('the mesh is empty');
  const ao = geometry.getAttribute('ao');
  const colours = new Float32Array(position.count * 3);
  for (let i = 0; i < position.count; ++i) {
    const grey = ao ? ao.getX(i) : 1.0;
    colours.set([grey, grey, grey], i * 3);
  }
  geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
  if (!geometry.getAttribute('normal')) geometry.computeVertexNormals();
  const material = new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide });
  if (viewer.mesh) {
    viewer.scene.remove(viewer.mesh);
    viewer.mesh.geometry.dispose();
    viewer.mesh.material.dispose();
  }
  const mesh = new THREE.Mesh(geometry, material);
  mesh.rotation.x = Math.PI;  // the camera frame of trajectory.txt has y down: show it upright
  viewer.scene.add(mesh);
  viewer.mesh = mesh;

  geometry.computeBoundingSphere();
  const sphere = geometry.boundingSphere;
  const centre = sphere.center.clone().applyEuler(mesh.rotation);
  const distance = sphere.radius / Math.sin((viewer.camera.fov * Math.PI) / 360);
  viewer.camera.position.copy(centre).add(new THREE.Vector3(0, 0, distance));
  viewer.camera.near = distance / 100;
  viewer.camera.far = distance * 10;
  viewer.camera.updateProjectionMatrix();
  viewer.controls.target.copy(centre);
  viewer.controls.update();
  viewer.draw();
  const triangles = geometry.index ? geometry.index.count / 3 : position.count / 3;
  return { vertices: position.count, triangles };
}
